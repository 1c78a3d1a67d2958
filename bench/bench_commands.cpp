#include "bench_commands.hpp"

#include <memory>

#include "build_trace.hpp"
#include "bvh_bench.hpp"
#include "dist_bench.hpp"
#include "hybrid_bench.hpp"
#include "kd_costs.hpp"
#include "knn_bench.hpp"
#include "neural_bench.hpp"

namespace splitray::bench {

void add_bench_subcommands(CLI::App& bench) {
  auto neural_options = std::make_shared<NeuralBenchOptions>();
  CLI::App* neural = bench.add_subcommand(
      "neural",
      "Neural top + expansion (paper 003) against the expansion builder alone on held-out meshes: "
      "SAH/VVH cost, Mrays/s, k-NN queries/s and inference time for 10^4..10^6 primitives");
  add_neural_bench_options(*neural, *neural_options);
  neural->callback([neural_options] {
    // Non-zero when a neural tree answered differently: the report says where.
    if (const int code = run_neural_bench(*neural_options); code != 0)
      throw CLI::RuntimeError(code);
  });

  auto build_trace_options = std::make_shared<BuildTraceOptions>();
  CLI::App* build_trace = bench.add_subcommand(
      "build-trace",
      "Build time, SAH cost, cost evaluations and Mrays/s (primary, diffuse) of every kd builder "
      "and Embree low/medium/high on every real mesh; JSON and Markdown reports");
  add_build_trace_options(*build_trace, *build_trace_options);
  build_trace->callback([build_trace_options] { build_trace_command(*build_trace_options); });

  auto bvh_options = std::make_shared<BvhBenchOptions>();
  CLI::App* bvh = bench.add_subcommand(
      "bvh",
      "Our BVHs (binned, sbvh) against Embree (medium, high; low too; and medium in its robust "
      "mode, the guarantee nearest to ours) on every benchmark mesh and "
      "any mesh given with its camera: build time and SAH cost, primary and diffuse Mrays/s from "
      "several viewpoints, single and batched, at 1 and all threads; nodes, boxes and triangle "
      "blocks per ray, and what a ray costs before its walk");
  add_bvh_bench_options(*bvh, *bvh_options);
  bvh->callback([bvh_options] {
    if (const int code = bvh_bench_command(*bvh_options); code != 0) throw CLI::RuntimeError(code);
  });

  auto kd_costs_options = std::make_shared<KdCostsOptions>();
  CLI::App* kd_costs = bench.add_subcommand(
      "kd-costs",
      "The kd-tree's own SAH constants: trees built over a range of K_T, their expected node "
      "steps and triangle tests fitted to measured trace times (what a step costs in tests)");
  add_kd_costs_options(*kd_costs, *kd_costs_options);
  kd_costs->callback([kd_costs_options] { kd_costs_command(*kd_costs_options); });

  auto dist_options = std::make_shared<DistBenchOptions>();
  CLI::App* dist = bench.add_subcommand(
      "dist",
      "Animation frames across processes: mpirun with 1, 2, 4 ranks against the single process "
      "(frames/s, communication share, identical images) and a projection to 8-64 nodes");
  add_dist_bench_options(*dist, *dist_options);
  dist->callback([dist_options] { dist_bench_command(*dist_options); });

  auto knn_options = std::make_shared<KnnBenchOptions>();
  CLI::App* knn = bench.add_subcommand(
      "knn",
      "Build time and queries/s of our point kd-trees (k-nearest for k = 1, 8, 16 and radius "
      "search) against nanoflann and FLANN on real meshes sampled to 1M points");
  add_knn_bench_options(*knn, *knn_options);
  knn->callback([knn_options] {
    // Non-zero when structures disagreed on the answers: the report says which.
    if (const int code = run_knn_bench(*knn_options); code != 0) throw CLI::RuntimeError(code);
  });

  auto hybrid_options = std::make_shared<HybridBenchOptions>();
  CLI::App* hybrid = bench.add_subcommand(
      "hybrid",
      "Hybrid GPU + CPU renderer (paper 002) against Whitted: frame times, per-pass times, CPU "
      "ray share, PSNR and wrong shadow pixels with and without refinement; JSON, Markdown, PNG");
  add_hybrid_bench_options(*hybrid, *hybrid_options);
  hybrid->callback([hybrid_options] {
    // Non-zero when a target that holds on every machine was missed: the report says which.
    if (const int code = run_hybrid_bench(*hybrid_options); code != 0)
      throw CLI::RuntimeError(code);
  });
}

}  // namespace splitray::bench

// splitray-train: trains the neural top builder (paper 003) with libtorch on the CPU and
// writes the weights in the plain C++ format of neural_model.hpp, with the loss per epoch as
// CSV and PNG and a tree-quality report against a greedy top of the same depth.
#include <fmt/core.h>

#include <CLI/CLI.hpp>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <thread>

#include "evaluate.hpp"
#include "json_output.hpp"
#include "loss_report.hpp"
#include "progress.hpp"
#include "splitray/core/errors.hpp"
#include "splitray/core/image.hpp"
#include "train_data.hpp"
#include "trainer.hpp"

namespace fs = std::filesystem;
using namespace splitray;
using namespace splitray::train;

namespace {

std::string stem_of(const std::string& out) {
  std::string s = out;
  if (s.size() > 4 && s.ends_with(".bin")) s.resize(s.size() - 4);
  return s;
}

int run(int argc, char** argv) {
  CLI::App app{
      "splitray-train: trains the neural top builder of paper 003 (per-level encoders, the "
      "recursive SAH/VVH tree cost over all axis choices) with libtorch on the CPU. Writes "
      "OUT (weights), OUT-stem.loss.csv, OUT-stem.loss.png and OUT-stem.report.json"};
  std::string cost_name;
  TrainOptions t;
  DataOptions d;
  std::vector<std::string> data, eval_files;
  std::string out;
  int depth = 0, eval_sets = 8;
  bool quiet = false;
  app.add_option("--cost", cost_name, "Tree cost: sah (ray tracing) or vvh (nearest neighbours)")
      ->required()
      ->check(CLI::IsMember({"sah", "vvh"}));
  app.add_option("--depth", depth, "Levels of the inferred top (default: 6 for sah, 5 for vvh)")
      ->check(CLI::Range(1, 8));
  app.add_option("--samples", t.infer_points,
                 "M, the points inference draws (stored in the model; default 2048)")
      ->check(CLI::Range(16, 1 << 20));
  app.add_option("--train-samples", d.points,
                 "Points per training set (default 512; see models/README.md)")
      ->check(CLI::Range(8, 1 << 16));
  app.add_option("--data", data, "Training meshes (OBJ/PLY/..., .gz allowed)")
      ->required()
      ->check(CLI::ExistingFile);
  app.add_option("--out", out, "Model file to write (e.g. models/sah.bin)")->required();
  app.add_option("--epochs", t.epochs, "Passes over the training sets (default 30)")
      ->check(CLI::Range(1, 100000));
  app.add_option("--batch", t.batch, "Sets per Adam step (default 8)")->check(CLI::Range(1, 4096));
  app.add_option("--lr", t.lr, "Adam learning rate (default 1e-3)")->check(CLI::PositiveNumber);
  app.add_option("--width", t.width, "Width of the encoder layers (default 32)")
      ->check(CLI::Range(2, 1024));
  app.add_option("--point-layers", t.point_layers,
                 "Per-point layers (1x1 convolutions) of each encoder (default 1)")
      ->check(CLI::Range(1, 8));
  app.add_option("--head-layers", t.head_layers, "Head layers after the pooling (default 2)")
      ->check(CLI::Range(1, 8));
  CLI::Option* tree_depth =
      app.add_option("--tree-depth", d.tree_depth,
                     "Levels of the greedy trees whose nodes give the sets (default: depth - 1 "
                     "with --lookahead, else 3)")
          ->check(CLI::Range(0, 8));
  app.add_option("--lookahead", t.lookahead,
                 "Levels of full expansion below each set's own level (default 3; 0 = the "
                 "full depth from the root for every set, the paper's unreduced form)")
      ->check(CLI::Range(0, 8));
  app.add_option("--rotations", d.rotations, "Randomly rotated copies per set (default 2)")
      ->check(CLI::Range(0, 64));
  app.add_option("--pool", d.pool,
                 "Surface samples per mesh the sets are drawn from (default 200000)")
      ->check(CLI::Range(1000, 100000000));
  app.add_option("--sharpness", t.sharpness, "t of the soft minimum (§5.1, default 1)")
      ->check(CLI::PositiveNumber);
  app.add_option("--count-eps", t.count_eps,
                 "e of the replacement count gradient (§5.3), in mean spacings of the node's "
                 "points (default 0.5)")
      ->check(CLI::PositiveNumber);
  app.add_option("--eval", eval_files,
                 "Extra meshes for the quality report (whole-mesh samples; not trained on)")
      ->check(CLI::ExistingFile);
  app.add_option("--eval-sets", eval_sets,
                 "Whole-mesh sample sets per mesh in the report (default 8)")
      ->check(CLI::Range(1, 1000));
  app.add_option("--threads", t.threads,
                 "libtorch threads (default 1: the tensors are small, and OpenMP threads spin "
                 "on a shared machine)")
      ->check(CLI::Range(1, 256));
  app.add_option("--seed", t.seed, "Seed of the sets, rotations and initial weights");
  app.add_flag("--quiet", quiet, "No per-epoch lines on stderr");
  cli::JsonOutput json;
  cli::add_json_options(app, json, "the quality report (also written to NAME.report.json)");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }

  t.cost = cost_name == "sah" ? NeuralCost::sah : NeuralCost::vvh;
  t.depth = depth > 0 ? depth : (t.cost == NeuralCost::sah ? 6 : 5);
  if (t.cost == NeuralCost::vvh) {  // the paper's VVH constants (§6.3)
    t.traversal_cost = 1.2f;
    t.intersection_cost = 1;
  }
  d.levels_from_nodes = t.lookahead > 0;
  if (tree_depth->count() == 0) d.tree_depth = t.lookahead > 0 ? t.depth - 1 : 3;
  d.cost = t.cost;
  d.seed = t.seed;
  d.traversal_cost = t.traversal_cost;
  d.intersection_cost = t.intersection_cost;
  const fs::path out_path(out);
  if (out_path.has_parent_path() && !fs::is_directory(out_path.parent_path()))
    throw Error("--out", "folder " + out_path.parent_path().string() + " does not exist");
  const std::string stem = stem_of(out);

  cli::ProgressBar bar("train");
  bar.status("building the training sets");
  const std::vector<TrainSet> sets = build_training_sets(data, d);
  if (!quiet)
    fmt::print(stderr, "splitray-train: {} sets of {} points from {} meshes, depth {}\n",
               sets.size(), d.points, data.size(), t.depth);
  const TrainResult result = train_model(
      sets, t, [&](double f) { bar.update(f); },
      [&](const EpochStats& e) {
        if (quiet) return;
        bar.finish();
        // Epoch 0 is the untrained network's evaluation, not a pass over the data.
        const std::string name =
            e.epoch == 0 ? "before training" : fmt::format("epoch {}/{}", e.epoch, t.epochs);
        fmt::print(stderr, "{}: loss {:.6f} (tree {:.6f}, bound {:.6f}), cost {:.4f}, {:.0f} s\n",
                   name, e.loss, e.tree, e.bound, e.cost, e.seconds);
      });
  bar.finish();

  nlohmann::ordered_json meta;
  meta["trainer"] = "splitray-train (libtorch)";
  meta["cost"] = cost_name;
  meta["depth"] = t.depth;
  meta["meshes"] = data;
  meta["sets"] = sets.size();
  meta["train_samples"] = d.points;
  meta["tree_depth"] = d.tree_depth;
  meta["lookahead"] = t.lookahead;
  meta["rotations"] = d.rotations;
  meta["epochs"] = t.epochs;
  meta["batch"] = t.batch;
  meta["lr"] = t.lr;
  meta["width"] = t.width;
  meta["point_layers"] = t.point_layers;
  meta["head_layers"] = t.head_layers;
  meta["parameters"] = result.parameters;
  meta["sharpness"] = t.sharpness;
  meta["count_eps"] = t.count_eps;
  meta["seed"] = t.seed;
  meta["final_loss"] = result.epochs.back().loss;
  meta["seconds"] = result.epochs.back().seconds;
  NeuralModel model = result.model;
  model.metadata = meta.dump();
  write_neural_model(model, out);
  write_loss_csv(stem + ".loss.csv", result.epochs);
  try {
    write_loss_png(stem + ".loss.png", stem + ".loss.csv");
  } catch (const Error& e) {  // the model is written: a missing plot is no reason to fail
    fmt::print(stderr, "splitray-train: warning: no loss plot: {}\n", e.what());
  }

  // Quality against a greedy top of the same depth, at inference's M, on fresh sets.
  DataOptions e = d;
  e.points = t.infer_points;
  e.seed = t.seed + 7777;
  nlohmann::ordered_json report;
  report["model"] = out;
  report["metadata"] = meta;
  report["training_meshes"] = evaluate(model, whole_mesh_sets(data, e, eval_sets), t);
  e.tree_depth = 2;
  e.rotations = 1;
  e.levels_from_nodes = false;
  report["training_style_sets"] = evaluate(model, build_training_sets(data, e), t);
  if (!eval_files.empty())
    report["held_out_meshes"] = evaluate(model, whole_mesh_sets(eval_files, e, eval_sets), t);
  write_file_atomically(stem + ".report.json", report.dump(2) + "\n");
  cli::emit_json(json, report);
  if (!json.print)
    fmt::print("splitray-train: wrote {}, {}.loss.csv, {}.loss.png, {}.report.json\n", out, stem,
               stem, stem);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {
    fmt::print(stderr, "splitray-train: {}\n", e.what());
    return 1;
  }
}

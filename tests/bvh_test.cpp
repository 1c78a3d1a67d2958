// BVH builders (binned, sbvh, Embree's custom builder), refit, and the kd-top -> BVH
// conversion: every answer must be exactly brute's (hierarchy_oracle.hpp).
#include "splitray/accel/bvh/bvh.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <span>

#include "hierarchy_oracle.hpp"
#include "hostile_geometry.hpp"
#include "splitray/accel/bvh/kd_top_bvh.hpp"
#include "splitray/accel/bvh/object_split.hpp"
#include "splitray/accel/robust_ray.hpp"
#include "splitray/core/camera.hpp"
#include "splitray/core/errors.hpp"
#include "splitray/core/huge_page_allocator.hpp"
#include "splitray/core/parallel.hpp"
#include "splitray/core/random.hpp"

namespace splitray::test {
namespace {

const char* const kHorse = "horse/horse.obj.gz";

void check_every_builder(const Reference& ref, const std::string& mesh) {
  for (const std::string builder : {"binned", "sbvh"}) {
    BuildConfig config;
    config.builder = builder;
    const auto accel = make_accel("bvh", ref.tris, config);
    expect_same_answers(ref.brute, answers_of(*accel, ref.rays), ref.rays,
                        mesh + " bvh " + builder);
  }
  const Bvh embree = Bvh::build(ref.tris, "embree", BvhBuildOptions{});
  expect_same_answers(ref.brute, answers_of_structure(embree, ref.rays), ref.rays,
                      mesh + " bvh embree");
}

TEST(Bvh, EveryBuilderMatchesBruteOnHorse) {
  check_every_builder(reference(vendored_file(kHorse)), "horse");
}

TEST(Bvh, EveryBuilderMatchesBruteOnSibenik) {
  SPLITRAY_REQUIRE_SHARED(path, "static_sibenik/sibenik.obj");
  check_every_builder(reference(path, 20000), "sibenik");
}

TEST(Bvh, EveryBuilderMatchesBruteOnLion) {
  SPLITRAY_REQUIRE_SHARED(path, "static_sumner_cat_lion_poses/lion-poses/lion-reference.obj.gz");
  check_every_builder(reference(path), "lion");
}

TEST(Bvh, EveryBuilderMatchesBruteOnCornellBox) {  // axis-aligned walls: rays in their planes
  SPLITRAY_REQUIRE_SHARED(path, "static_cornell_box/cornell_box.obj");
  check_every_builder(reference(path, 20000), "cornell box");
}

std::vector<Triangle> grid_in_plane(int n) {  // an axis-aligned plane of 2 n^2 triangles
  std::vector<Triangle> tris;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const auto x0 = static_cast<float>(i), x1 = x0 + 1, y0 = static_cast<float>(j), y1 = y0 + 1;
      tris.push_back({{x0, y0, 2}, {x1, y0, 2}, {x1, y1, 2}});
      tris.push_back({{x0, y0, 2}, {x1, y1, 2}, {x0, y1, 2}});
    }
  return tris;
}

TEST(Bvh, DegenerateInputsMatchBrute) {
  std::vector<std::pair<std::string, std::vector<Triangle>>> cases;
  cases.push_back({"one triangle", {{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}}});
  cases.push_back({"plane grid", grid_in_plane(24)});
  std::vector<Triangle> same(300, Triangle{{0, 0, 0}, {1, 0, 0}, {0, 1, 1}});  // coincident centres
  same.push_back({{5, 5, 5}, {6, 5, 5}, {5, 6, 5}});
  cases.push_back({"300 identical", same});
  std::vector<Triangle> slivers = grid_in_plane(8);
  for (int i = 0; i < 50; ++i) {  // zero-area triangles (segments and points) among real ones
    const auto f = static_cast<float>(i) * 0.1f;
    slivers.push_back({{f, 0, 2}, {f + 1, 1, 2}, {f + 2, 2, 2}});
    slivers.push_back({{f, f, 2}, {f, f, 2}, {f, f, 2}});
  }
  cases.push_back({"slivers", slivers});
  for (const auto& [name, tris] : cases) {
    const std::vector<Ray> rays = hard_rays(tris, 4000, 7);
    const Answers brute = brute_answers(tris, rays);
    for (const std::string builder : {"binned", "sbvh", "embree"}) {
      const Bvh bvh = Bvh::build(tris, builder, BvhBuildOptions{});
      const Answers got = answers_of_structure(bvh, rays);
      for (std::size_t i = 0; i < rays.size(); ++i) {
        ASSERT_TRUE(same_hit(brute.hits[i], got.hits[i])) << name << " " << builder << " ray " << i;
        ASSERT_EQ(brute.occluded[i], got.occluded[i]) << name << " " << builder << " ray " << i;
      }
    }
  }
}

// Groups of sixteen rays that the batched calls walk as packets (same direction signs, close
// directions): each of the hard rays with fifteen companions from origins moved a little, and
// primary rays of a camera, row by row. Every ray's answer must still be brute's.
std::vector<Ray> coherent_groups(const std::vector<Triangle>& tris, std::size_t groups) {
  const std::vector<Ray> hard = hard_rays(tris, groups, 11);
  const float step = length(bounds_of(tris).extent()) * 1e-3f;
  Pcg32 rng(5);
  std::vector<Ray> rays;
  for (const Ray& base : hard)
    for (int k = 0; k < WideBvh::kPacketRays; ++k) {
      Ray r = base;
      if (k > 0)
        for (int a = 0; a < 3; ++a)
          r.org[a] += step * (rng.next_float() - 0.5f) * static_cast<float>(k);
      rays.push_back(r);
    }
  Camera camera = Camera::frame(bounds_of(tris));
  for (int y = 0; y < 48; ++y)
    for (int x = 0; x < 64; ++x) rays.push_back(camera.generate(x + 0.5f, y + 0.5f, 64, 48));
  return rays;
}

TEST(Bvh, PacketsMatchBrute) {
  const Reference& ref = reference(vendored_file(kHorse));
  std::vector<std::pair<std::string, std::vector<Triangle>>> cases = {
      {"horse", ref.tris}, {"plane grid", grid_in_plane(24)}};
  // Hostile geometry (slivers, coplanar and duplicated triangles, a few ulps thick), where the
  // packets' leaves are tested triangle by triangle against many rays at shared edges.
  for (int i = 0; i < 8; ++i) {
    test::HostileMesh mesh = test::hostile_mesh(0x26, i);
    cases.emplace_back(mesh.name, std::move(mesh.tris));
  }
  for (const auto& [name, tris] : cases) {
    const std::vector<Ray> rays = coherent_groups(tris, 400);
    const Answers brute = brute_answers(tris, rays);
    for (const std::string builder : {"binned", "sbvh"}) {
      BuildConfig config;
      config.builder = builder;
      const auto accel = make_accel("bvh", tris, config);
      expect_same_answers(brute, answers_of(*accel, rays), rays, name + " bvh " + builder);
      if constexpr (WideBvh::kPackets) {  // every group as a packet, whatever its coherence
        const Bvh bvh = Bvh::build(tris, builder, BvhBuildOptions::from(config));
        std::size_t wrong = 0, packets = 0;
        for (std::size_t i = 0; i + WideBvh::kPacketRays <= rays.size();
             i += WideBvh::kPacketRays) {
          const std::span<const Ray> group(rays.data() + i, WideBvh::kPacketRays);
          const Aabb box = bvh.bounds();
          Hit hits[WideBvh::kPacketRays];
          // Every group with the same direction signs, the packet walk's precondition, whatever
          // the angles between its rays.
          if (!bvh.wide().intersect_packet(group, box, coordinate_magnitude(box), hits, true))
            continue;
          ++packets;
          const unsigned occluded =
              bvh.wide().occluded_packet(group, box, coordinate_magnitude(box), true).value();
          // A partial packet (the last group of a batch), 1 to 15 rays.
          const std::size_t part = 1 + (i / WideBvh::kPacketRays) % (WideBvh::kPacketRays - 1);
          Hit part_hits[WideBvh::kPacketRays];
          bvh.wide().intersect_packet(group.first(part), box, coordinate_magnitude(box), part_hits,
                                      true);
          const unsigned part_occluded =
              bvh.wide()
                  .occluded_packet(group.first(part), box, coordinate_magnitude(box), true)
                  .value();
          wrong += part_occluded >> part == 0 ? 0 : 1;  // no answer for rays not given
          for (int r = 0; r < WideBvh::kPacketRays; ++r) {
            Hit expected = brute.hits[i + r];
            if (!expected.found()) expected.t = group[r].tmax;  // the packet leaves t = tmax
            wrong += same_hit(expected, hits[r]) ? 0 : 1;
            wrong += ((occluded >> r) & 1u) == brute.occluded[i + r] ? 0 : 1;
            if (static_cast<std::size_t>(r) < part) {
              wrong += same_hit(expected, part_hits[r]) ? 0 : 1;
              wrong += ((part_occluded >> r) & 1u) == brute.occluded[i + r] ? 0 : 1;
            }
          }
        }
        EXPECT_EQ(wrong, 0u) << name << " " << builder;
        EXPECT_GT(packets, rays.size() / WideBvh::kPacketRays / 2) << name << " " << builder;
      }
    }
  }
}

TEST(Bvh, PacketsTakeOnlyCoherentRays) {
  if constexpr (WideBvh::kPackets) {
    const Reference& ref = reference(vendored_file(kHorse));
    const Bvh bvh = Bvh::build(ref.tris, "binned", BvhBuildOptions{});
    const Aabb box = bvh.bounds();
    const auto rays_towards = [&](const Vec3& a, const Vec3& b) {
      std::vector<Ray> rays(WideBvh::kPacketRays, Ray{box.center() - a * 10.0f, a});
      rays.back().dir = b;
      return rays;
    };
    const auto takes = [&](const std::vector<Ray>& rays, bool any_angle) {
      Hit hits[WideBvh::kPacketRays];
      const bool closest =
          bvh.wide().intersect_packet(rays, box, coordinate_magnitude(box), hits, any_angle);
      const bool any =
          bvh.wide().occluded_packet(rays, box, coordinate_magnitude(box), any_angle).has_value();
      EXPECT_EQ(closest, any);
      return closest;
    };
    const Vec3 along{1, 0.1f, 0.1f};
    EXPECT_TRUE(takes(rays_towards(along, along * 3.0f), false));       // same direction
    EXPECT_TRUE(takes(rays_towards(along, {1, 0.18f, 0.1f}), false));   // 4.5 degrees apart
    EXPECT_FALSE(takes(rays_towards(along, {1, 0.38f, 0.1f}), false));  // 15 degrees apart
    EXPECT_FALSE(takes(rays_towards(along, {1, 1.5f, 0.1f}), false));   // 50 degrees apart
    EXPECT_TRUE(takes(rays_towards(along, {1, 1.5f, 0.1f}), true));     // ... allowed
    EXPECT_FALSE(takes(rays_towards(along, {1, -0.1f, 0.1f}), true));   // other y sign
    EXPECT_FALSE(takes(rays_towards(along, {-1, 0.1f, 0.1f}), true));   // other x sign
  }
}

// The groups of the batched calls that make no packet: the root tested for eight rays at a time,
// then each ray walked alone from the children it entered. Every answer must be brute's, in
// groups of 1 to 16 rays of any directions (the rays of hard_rays, their directions brought to
// the domain of coordinates.hpp by powers of two).
TEST(Bvh, GroupsMatchBrute) {
  std::vector<std::pair<std::string, std::vector<Triangle>>> cases = {
      {"horse", reference(vendored_file(kHorse)).tris}, {"plane grid", grid_in_plane(24)}};
  for (int i = 0; i < 8; ++i) {
    test::HostileMesh mesh = test::hostile_mesh(0x27, i);
    cases.emplace_back(mesh.name, std::move(mesh.tris));
  }
  for (const auto& [name, tris] : cases) {
    std::vector<Ray> rays = hard_rays(tris, 2048, 0x9a);
    for (Ray& r : rays) {
      const float s = std::ldexp(1.0f, -std::ilogb(max_component(abs(r.dir))));
      r = Ray{r.org, r.dir * s, r.tmin / s, r.tmax / s};
    }
    const Answers brute = brute_answers(tris, rays);
    for (const std::string builder : {"binned", "sbvh"}) {
      BuildConfig config;
      config.builder = builder;
      const Bvh bvh = Bvh::build(tris, builder, BvhBuildOptions::from(config));
      const Aabb box = bvh.bounds();
      std::size_t wrong = 0;
      for (std::size_t i = 0; i + WideBvh::kPacketRays <= rays.size(); i += WideBvh::kPacketRays) {
        const std::size_t size = 1 + (i / WideBvh::kPacketRays) % WideBvh::kPacketRays;
        const std::span<const Ray> group(rays.data() + i, size);
        Hit hits[WideBvh::kPacketRays];
        std::uint8_t occluded[WideBvh::kPacketRays];
        if (!bvh.wide().intersect_group(group, box, coordinate_magnitude(box), hits))
          GTEST_SKIP() << "groups need AVX and FMA";
        ASSERT_TRUE(bvh.wide().occluded_group(group, box, coordinate_magnitude(box), occluded));
        for (std::size_t r = 0; r < size; ++r) {
          Hit expected = brute.hits[i + r];
          if (!expected.found()) expected.t = group[r].tmax;  // the group leaves t = tmax
          wrong += same_hit(expected, hits[r]) ? 0 : 1;
          wrong += occluded[r] == brute.occluded[i + r] ? 0 : 1;
        }
      }
      EXPECT_EQ(wrong, 0u) << name << " " << builder;
    }
  }
}

TEST(Bvh, TreeAndHitsDoNotDependOnThreadCount) {
  const Reference& ref = reference(vendored_file(kHorse));
  for (const std::string builder : {"binned", "sbvh"}) {
    std::vector<Bvh> trees;
    std::vector<Answers> answers;
    for (const int threads : {1, 2}) {
      ThreadLimit limit(threads);
      trees.push_back(Bvh::build(ref.tris, builder, BvhBuildOptions{}));
      answers.push_back(answers_of_structure(trees.back(), ref.rays));
    }
    const auto a = trees[0].nodes(), b = trees[1].nodes();
    ASSERT_EQ(a.size(), b.size()) << builder;
    EXPECT_EQ(std::memcmp(a.data(), b.data(), a.size_bytes()), 0) << builder;
    EXPECT_TRUE(std::equal(trees[0].prim_ids().begin(), trees[0].prim_ids().end(),
                           trees[1].prim_ids().begin(), trees[1].prim_ids().end()))
        << builder;
    expect_same_answers(answers[0], answers[1], ref.rays, "1 vs 2 threads " + builder);
  }
}

// The dragon's top nodes (32768 references or more) are binned and partitioned in parallel,
// over chunks that must not depend on the thread count.
TEST(Bvh, LargeTreesDoNotDependOnThreadCount) {
  const std::vector<Triangle> tris = load_triangles(vendored_file("dragon_100k/dragon.obj.gz"));
  for (const std::string builder : {"binned", "sbvh"}) {
    std::vector<Bvh> trees;
    for (const int threads : {1, 2}) {
      ThreadLimit limit(threads);
      trees.push_back(Bvh::build(tris, builder, BvhBuildOptions{}));
    }
    const auto same = [](auto a, auto b) {
      return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size_bytes()) == 0;
    };
    EXPECT_TRUE(same(trees[0].nodes(), trees[1].nodes())) << builder;
    EXPECT_TRUE(same(trees[0].prim_ids(), trees[1].prim_ids())) << builder;
    EXPECT_TRUE(same(trees[0].wide().nodes(), trees[1].wide().nodes())) << builder;
  }
}

// The parallel partition splits a span as the sequential one does (the same references on
// each side, the same bounds), only in another order.
TEST(Bvh, ParallelPartitionMatchesSequential) {
  const std::vector<Triangle> tris = load_triangles(vendored_file("dragon_100k/dragon.obj.gz"));
  std::vector<BvhRef> a = make_prim_refs(tris), b = a;
  const RefBounds bounds = ref_bounds(a);
  const BvhBuildOptions options;
  std::uint64_t evals = 0;
  const ObjectSplit split = find_object_split(a, bounds, options, evals);
  ASSERT_GE(split.axis, 0);
  const CenterBins map(bounds.centers, bin_count(options, a.size()));
  RefBounds la, ra, lb, rb;
  const std::size_t na = partition_refs(a, map, split, la, ra);
  const std::size_t nb = partition_refs_parallel(b, map, split, lb, rb);
  ASSERT_EQ(na, nb);
  EXPECT_EQ(na, split.n_left);
  const auto ids = [](std::span<const BvhRef> refs) {
    std::vector<std::uint32_t> out;
    for (const BvhRef& r : refs) out.push_back(r.prim);
    std::sort(out.begin(), out.end());
    return out;
  };
  EXPECT_EQ(ids(std::span(a).first(na)), ids(std::span(b).first(nb)));
  EXPECT_EQ(ids(std::span(a).subspan(na)), ids(std::span(b).subspan(nb)));
  for (const auto& [x, y] : {std::pair{la, lb}, std::pair{ra, rb}}) {
    EXPECT_EQ(std::memcmp(&x.box, &y.box, sizeof(Aabb)), 0);
    EXPECT_EQ(std::memcmp(&x.centers, &y.centers, sizeof(Aabb)), 0);
  }
  EXPECT_EQ(std::memcmp(&la.box, &split.left, sizeof(Aabb)), 0);  // the binning's bounds
  EXPECT_EQ(std::memcmp(&ra.box, &split.right, sizeof(Aabb)), 0);
}

TEST(Bvh, WideLayoutKeepsEveryLeafInFullNodes) {
  const Reference& ref = reference(vendored_file(kHorse));
  for (const std::string builder : {"binned", "sbvh"}) {
    const Bvh bvh = Bvh::build(ref.tris, builder, BvhBuildOptions{});
    std::size_t leaves = 0;
    for (const BvhNode& n : bvh.nodes()) leaves += n.leaf() ? 1 : 0;
    const auto wide = bvh.wide().nodes();
    std::size_t leaf_slots = 0, slots = 0;
    for (const WideNode& w : wide)
      for (int i = 0; i < kWideWidth; ++i) {
        const bool used = w.planes[0][i] <= w.planes[3][i];
        slots += used ? 1 : 0;
        if (used && w.count[i] > 0) ++leaf_slots;
        if (used && w.count[i] == 0) {
          EXPECT_LT(w.child[i], wide.size()) << builder;
        }
      }
    EXPECT_EQ(leaf_slots, leaves) << builder;               // every binary leaf, once
    EXPECT_EQ(slots, wide.size() - 1 + leaves) << builder;  // every wide node but the root
    // The collapse fills nodes: on average more than half of the slots are used.
    EXPECT_GT(2 * slots, wide.size() * static_cast<std::size_t>(kWideWidth)) << builder;
  }
}

TEST(HugePageAllocator, AlignsAndKeepsContents) {
  HugePageVector<std::uint32_t> small(1000), large;
  EXPECT_EQ(reinterpret_cast<std::uintptr_t>(small.data()) % 64, 0u);
  for (std::uint32_t i = 0; i < 3'000'000; ++i) large.push_back(i);  // grows through 1 MiB
  EXPECT_EQ(reinterpret_cast<std::uintptr_t>(large.data()) % (std::size_t{1} << 21), 0u);
  bool intact = true;
  for (std::uint32_t i = 0; i < large.size(); ++i) intact = intact && large[i] == i;
  EXPECT_TRUE(intact);
  HugePageVector<std::uint32_t> copy = large;
  large.clear();
  large.shrink_to_fit();
  EXPECT_EQ(copy.size(), 3'000'000u);
  EXPECT_EQ(copy.back(), 2'999'999u);
}

#if defined(__linux__) && defined(MADV_HUGEPAGE)
TEST(HugePageAllocator, ReusesFreedRangesOfFittingSize) {
  HugePageAllocator<char> allocator;
  const std::size_t size = std::size_t{41} << 20;  // 42 MiB ranges: no other test frees one
  char* const first = allocator.allocate(size);
  first[0] = 42;
  first[size - 1] = 43;
  allocator.deallocate(first, size);
  // The same range again, with what was written (a range mapped afresh would read zeros).
  char* const again = allocator.allocate(size - 1000);
  ASSERT_EQ(again, first);
  EXPECT_EQ(again[0], 42);
  EXPECT_EQ(again[size - 1], 43);
  // Kept ranges serve sizes they fit, at most a quarter larger.
  char* const larger = allocator.allocate(std::size_t{60} << 20);
  allocator.deallocate(again, size - 1000);
  char* const smaller = allocator.allocate(std::size_t{20} << 20);
  EXPECT_NE(larger, first);
  EXPECT_NE(smaller, first);
  allocator.deallocate(smaller, std::size_t{20} << 20);
  allocator.deallocate(larger, std::size_t{60} << 20);
}
#endif

TEST(Bvh, StatsDescribeTheTree) {
  const Reference& ref = reference(vendored_file(kHorse));
  std::map<std::string, AccelStats> stats;
  for (const std::string builder : {"binned", "sbvh"}) {
    BuildConfig config;
    config.builder = builder;
    const AccelStats s = make_accel("bvh", ref.tris, config)->stats();
    EXPECT_EQ(s.accel, "bvh");
    EXPECT_EQ(s.builder, builder);
    EXPECT_EQ(s.prims, ref.tris.size());
    EXPECT_EQ(s.nodes, 2 * s.leaves - 1) << builder;
    EXPECT_GT(s.leaves, ref.tris.size() / 8) << builder;
    EXPECT_LE(s.max_depth, 64);
    EXPECT_GT(s.mean_leaf_depth, 8);
    EXPECT_GE(s.prim_refs, s.prims);
    EXPECT_GT(s.bytes, s.nodes * 32);
    ASSERT_TRUE(s.sah_cost.has_value());
    EXPECT_GT(*s.sah_cost, 0);
    EXPECT_GT(s.build_ms, 0);
    stats[builder] = s;
  }
  EXPECT_EQ(stats["binned"].prim_refs, ref.tris.size());
  EXPECT_GT(stats["sbvh"].prim_refs,
            ref.tris.size());  // spatial splits reference some triangles twice
  EXPECT_LT(*stats["sbvh"].sah_cost, *stats["binned"].sah_cost);
}

// The counted walk (the benchmark's profile) gives the plain walk's answers, and finds each
// ray's closest hit in exactly one leaf of the binned tree (every triangle is in one leaf) and
// in at least one of the SBVH's (spatial splits put some in several).
TEST(Bvh, CountedWalkFindsEachHitInItsLeaves) {
  const Reference& ref = reference(vendored_file(kHorse));
  for (const std::string builder : {"binned", "sbvh"}) {
    const Bvh bvh = Bvh::build(ref.tris, builder, BvhBuildOptions{});
    WideBvhCounts counts;
    std::uint64_t hits = 0;
    for (std::size_t i = 0; i < ref.rays.size(); ++i) {
      const Hit hit = bvh.intersect_counted(ref.rays[i], counts);
      ASSERT_TRUE(same_hit(ref.brute.hits[i], hit)) << builder << " ray " << i;
      hits += hit.found() ? 1 : 0;
    }
    EXPECT_EQ(counts.rays, ref.rays.size());
    EXPECT_EQ(counts.hits, hits);
    EXPECT_GT(hits, ref.rays.size() / 4) << builder;
    if (builder == "binned") {
      EXPECT_EQ(counts.hit_leaves, hits);
    } else {
      EXPECT_GT(counts.hit_leaves, hits);
    }
    // Each ray that hits enters the leaf where it finds its hit before it is late.
    EXPECT_GT(counts.late_leaves, 0u) << builder;
    EXPECT_LE(counts.late_leaves + hits, counts.leaves) << builder;
  }
}

// Every box is no larger than what it holds: an interior node's than its children's, a leaf's
// than its triangles' (spatial splits clip them). A spatial split that failed once left its
// sides' bounds behind in the object split's children (the Cornell box's SBVH cost 360 against
// the binned tree's 333).
TEST(Bvh, BoxesHoldNoMoreThanTheirContents) {
  SPLITRAY_REQUIRE_SHARED(box_path, "static_cornell_box/cornell_box.obj");
  for (const auto& [path, rays] :
       {std::pair{std::string(box_path), 20000}, {vendored_file(kHorse), 24000}}) {
    const Reference& ref = reference(path, rays);
    for (const std::string builder : {"binned", "sbvh"}) {
      const Bvh bvh = Bvh::build(ref.tris, builder, BvhBuildOptions{});
      const auto nodes = bvh.nodes();
      const auto ids = bvh.prim_ids();
      for (std::size_t i = 0; i < nodes.size(); ++i) {
        const BvhNode& n = nodes[i];
        Aabb contents;
        if (n.leaf()) {
          for (std::uint32_t k = 0; k < n.count(); ++k)
            contents.extend(ref.tris[ids[n.index + k]].bounds());
        } else {
          contents = merge(nodes[n.index].box(), nodes[n.index + 1].box());
        }
        const Aabb both = merge(contents, n.box());
        ASSERT_EQ(both.lo, contents.lo) << path << " " << builder << " node " << i;
        ASSERT_EQ(both.hi, contents.hi) << path << " " << builder << " node " << i;
      }
    }
  }
}

// Fans of eight triangles in one plane, their apexes a few float steps above their rims (as the
// floors of the Sponza atrium): spatial splits clip them into nodes only a few steps thick.
std::vector<Triangle> nearly_flat_fans(int fans, std::uint64_t seed) {
  Pcg32 rng(seed);
  const float rim = 7.22148705f, apex = 7.221488f;
  std::vector<Triangle> tris;
  for (int k = 0; k < fans; ++k) {
    const float cx = 20 * rng.next_float() - 10, cy = 20 * rng.next_float() - 10;
    const float r = 2 + 4 * rng.next_float(), a0 = 6.28f * rng.next_float();
    const auto at = [&](int i) {
      const float a = a0 + 0.15f * static_cast<float>(i);
      return Vec3{cx + r * std::cos(a), cy + r * std::sin(a), rim};
    };
    for (int i = 0; i < 8; ++i) tris.push_back({{cx, cy, apex}, at(i), at(i + 1)});
  }
  return tris;
}

// A node that could be a leaf is split only when the split's SAH cost, from the boxes and
// references of its two leaves, is below the leaf's. The SBVH once fell back to the object
// split whenever the spatial split it had chosen could not be made, whatever that cost (nodes
// a few float steps thick, where the estimate of a spatial split is rounding): Sponza's SBVH
// made 109 such splits, each costing about twice the leaf.
TEST(Bvh, SmallNodesAreSplitOnlyWhenThatIsCheaper) {
  const BvhBuildOptions options;
  std::vector<std::pair<std::string, std::vector<Triangle>>> cases;
  for (const std::uint64_t seed : {1, 2, 3}) cases.push_back({"fans", nearly_flat_fans(400, seed)});
  cases.push_back({"horse", reference(vendored_file(kHorse)).tris});
  std::size_t checked = 0;
  for (const auto& [name, tris] : cases) {
    for (const std::string builder : {"binned", "sbvh"}) {
      const Bvh bvh = Bvh::build(tris, builder, options);
      const auto nodes = bvh.nodes();
      const SplitMeasure m = SplitMeasure::interior(nodes[0].box());  // as Bvh::build
      for (std::size_t i = 0; i < nodes.size(); ++i) {
        const BvhNode& n = nodes[i];
        if (n.leaf()) continue;
        const BvhNode &l = nodes[n.index], &r = nodes[n.index + 1];
        if (!l.leaf() || !r.leaf() || l.count() + r.count() > std::size_t(options.max_leaf))
          continue;
        ++checked;
        const float cost =
            bvh_split_cost(options, m(n.box()), m(l.box()), l.count(), m(r.box()), r.count());
        EXPECT_LT(cost, bvh_leaf_cost(options, l.count() + r.count()))
            << name << " " << builder << " node " << i;
      }
    }
  }
  EXPECT_GT(checked, 0u);  // not vacuous
}

// SplitMeasure::interior is the share of rays, with origins uniform in the scene's box and
// directions uniform, that enter a box: sampled, for boxes at the scene's boundary (where the
// chord of the scene through a box is near its mean, the model's one approximation; boxes in
// the middle see longer chords, and up to 30% more rays than the model gives). The SAH's half
// area alone is off by 54% for the small corner box.
TEST(Bvh, InteriorMeasureIsTheShareOfRaysStartingInside) {
  const Aabb scene{{0, 0, 0}, {4, 2, 1}};
  const SplitMeasure m = SplitMeasure::interior(scene);
  EXPECT_FLOAT_EQ(m(scene), 2 * scene.half_area());
  EXPECT_EQ(SplitMeasure::interior(Aabb{{0, 0, 0}, {4, 2, 0}}).volume_weight, 0.0f);  // flat
  EXPECT_EQ(SplitMeasure::interior(Aabb{{0, 0, 0}, {4, 2, 1e-40f}}).volume_weight, 0.0f);
  EXPECT_EQ(SplitMeasure{}(scene), scene.half_area());  // the SAH's
  Pcg32 rng(26);
  constexpr int kRays = 200000;
  for (const Aabb& box : {Aabb{{0, 0, 0}, {0.5f, 0.5f, 0.5f}}, Aabb{{0, 0, 0}, {2, 2, 1}}}) {
    int entered = 0;
    for (int i = 0; i < kRays; ++i) {
      const Vec3 org{4 * rng.next_float(), 2 * rng.next_float(), rng.next_float()};
      const Vec3 dir = uniform_sphere(rng.next_float(), rng.next_float());
      float t0 = 0, t1 = kInfinity;
      for (int a = 0; a < 3; ++a) {
        const float ta = (box.lo[a] - org[a]) / dir[a], tb = (box.hi[a] - org[a]) / dir[a];
        t0 = std::max(t0, std::min(ta, tb));
        t1 = std::min(t1, std::max(ta, tb));
      }
      entered += t0 <= t1 ? 1 : 0;
    }
    const double sampled = static_cast<double>(entered) / kRays;
    EXPECT_NEAR(m(box) / m(scene), sampled, 0.06 * sampled) << box.hi.x;
    if (box.hi.x == 0.5f) {  // what the test tells apart
      EXPECT_GT(box.half_area() / scene.half_area(), 1.4 * sampled);
    }
  }
}

// Triangles on one segment are degenerate (never hit), and their box has no area for the SAH
// to divide by: the builders keep them in one leaf instead of splitting them apart.
TEST(Bvh, TrianglesOnASegmentStayInOneLeaf) {
  std::vector<Triangle> tris;
  for (int i = 0; i < 6; ++i) {
    const auto y = static_cast<float>(i);
    tris.push_back({{0, y, 0}, {0, y + 0.5f, 0}, {0, y + 2, 0}});
  }
  for (const std::string builder : {"binned", "sbvh"}) {
    const Bvh bvh = Bvh::build(tris, builder, BvhBuildOptions{});
    EXPECT_EQ(bvh.nodes().size(), 1u) << builder;
  }
}

TEST(Bvh, SbvhAlphaControlsSpatialSplits) {
  const Reference& ref = reference(vendored_file(kHorse));
  BvhBuildOptions options;
  options.sbvh_alpha = 1e30f;  // never overlapping enough: object splits only
  const Bvh none = Bvh::build(ref.tris, "sbvh", options);
  EXPECT_EQ(none.prim_ids().size(), ref.tris.size());
  options.sbvh_alpha = 1e-5f;
  const Bvh some = Bvh::build(ref.tris, "sbvh", options);
  options.sbvh_alpha = 0;
  const Bvh most = Bvh::build(ref.tris, "sbvh", options);
  EXPECT_GT(some.prim_ids().size(), none.prim_ids().size());
  EXPECT_GE(most.prim_ids().size(), some.prim_ids().size());
  expect_same_answers(ref.brute, answers_of_structure(most, ref.rays), ref.rays, "sbvh alpha 0");
}

// Twists the horse about its vertical axis and swells it: same topology, moved vertices.
std::vector<Triangle> deform(const std::vector<Triangle>& tris) {
  const Aabb box = bounds_of(tris);
  const Vec3 c = box.center();
  const auto move = [&](const Vec3& p) {
    const float h = (p.y - box.lo.y) / box.extent().y, angle = 1.2f * h;
    const float x = p.x - c.x, z = p.z - c.z, s = 1 + 0.3f * h;
    return Vec3{c.x + s * (x * std::cos(angle) - z * std::sin(angle)), p.y + 0.2f * x,
                c.z + s * (x * std::sin(angle) + z * std::cos(angle))};
  };
  std::vector<Triangle> out;
  out.reserve(tris.size());
  for (const Triangle& t : tris) out.push_back({move(t.v0), move(t.v1), move(t.v2)});
  return out;
}

void check_refit(const std::vector<Triangle>& before, const std::vector<Triangle>& after,
                 const std::string& what) {
  const std::vector<Ray> rays = hard_rays(after, 20000, 11);
  const Answers brute = brute_answers(after, rays);
  for (const std::string builder : {"binned", "sbvh"}) {
    BuildConfig config;
    config.builder = builder;
    const auto refitted = make_accel("bvh", before, config);
    ASSERT_TRUE(refitted->refit(after));
    const Answers got = answers_of(*refitted, rays);
    expect_same_answers(brute, got, rays, what + " refit " + builder);
    const auto fresh = make_accel("bvh", after, config);
    expect_same_answers(answers_of(*fresh, rays), got, rays, what + " refit vs fresh " + builder);
    EXPECT_EQ(refitted->stats().nodes, make_accel("bvh", before, config)->stats().nodes);
  }
  // A kd-top BVH refits the same way.
  Bvh top = build_kd_top_bvh(before, 4, LeafExpander::binned, {});
  top.refit(after);
  expect_same_answers(brute, answers_of_structure(top, rays), rays, what + " refit kd-top");
}

TEST(Bvh, RefitAfterDeformationMatchesBruteAndFreshBuild) {
  const Reference& ref = reference(vendored_file(kHorse));
  check_refit(ref.tris, deform(ref.tris), "twisted horse");
}

TEST(Bvh, RefitFollowsHorseCollapseFrames) {
  SPLITRAY_REQUIRE_SHARED(first, "anim_horse_collapse/frames/horse-collapse-01.obj.gz");
  SPLITRAY_REQUIRE_SHARED(later, "anim_horse_collapse/frames/horse-collapse-06.obj.gz");
  const std::vector<Triangle> a = load_triangles(first), b = load_triangles(later);
  ASSERT_EQ(a.size(), b.size());
  check_refit(a, b, "horse collapse 01 -> 06");
}

TEST(Bvh, RefitRejectsAnotherMesh) {
  const Reference& ref = reference(vendored_file(kHorse));
  Bvh bvh = Bvh::build(ref.tris, "binned", BvhBuildOptions{});
  const std::vector<Triangle> fewer(ref.tris.begin(), ref.tris.end() - 1);
  EXPECT_THROW(bvh.refit(fewer), Error);
  EXPECT_FALSE(make_brute(ref.tris, {})->refit(ref.tris));  // the interface's default: cannot refit
}

TEST(Bvh, UnknownBuilderIsAnError) {
  const Reference& ref = reference(vendored_file(kHorse));
  BuildConfig config;
  config.builder = "lbvh";
  EXPECT_THROW(make_accel("bvh", ref.tris, config), Error);
  EXPECT_THROW(Bvh::build(ref.tris, "lbvh", BvhBuildOptions{}), Error);
}

// Brute's answers to centroid rays, once per mesh.
const Reference& centroid_reference(const Reference& mesh, std::size_t stride) {
  static std::map<const Reference*, std::unique_ptr<Reference>> cache;
  auto& slot = cache[&mesh];
  if (!slot) {
    slot = std::make_unique<Reference>();
    slot->rays = centroid_rays(mesh.tris, 3, stride);
    slot->brute = brute_answers(mesh.tris, slot->rays);
  }
  return *slot;
}

void expect_every_triangle_reachable(const Bvh& bvh, const Reference& mesh, const std::string& what,
                                     std::size_t stride = 1) {
  const Reference& ref = centroid_reference(mesh, stride);
  const Answers got = answers_of_structure(bvh, ref.rays);
  std::size_t wrong = 0;
  for (std::size_t i = 0; i < ref.rays.size(); ++i)
    if (!same_hit(ref.brute.hits[i], got.hits[i]) || !got.occluded[i]) ++wrong;
  EXPECT_EQ(wrong, 0u) << what;
}

TEST(KdTopBvh, EveryTriangleStaysReachable) {
  const Reference& ref = reference(vendored_file(kHorse));
  for (const LeafExpander expander :
       {LeafExpander::binned, LeafExpander::sbvh, LeafExpander::embree}) {
    TopBvhStats stats;
    const Bvh bvh = build_kd_top_bvh(ref.tris, 5, expander, {}, &stats);
    EXPECT_EQ(stats.top_depth, 5);
    EXPECT_LE(stats.top_leaves, 32u);
    EXPECT_GT(stats.top_leaves, 8u);
    EXPECT_GE(stats.refs, ref.tris.size());
    EXPECT_LT(stats.refs, ref.tris.size() * 11 / 10);  // clipping duplicates a few percent
    expect_every_triangle_reachable(bvh, ref, "kd top 5 horse");
    expect_same_answers(ref.brute, answers_of_structure(bvh, ref.rays), ref.rays, "kd top 5 horse");
  }
}

TEST(KdTopBvh, MatchesBruteOnSibenik) {
  SPLITRAY_REQUIRE_SHARED(path, "static_sibenik/sibenik.obj");
  const Reference& ref = reference(path, 20000);
  const Bvh bvh = build_kd_top_bvh(ref.tris, 6, LeafExpander::sbvh, {});
  expect_same_answers(ref.brute, answers_of_structure(bvh, ref.rays), ref.rays, "kd top 6 sibenik");
  expect_every_triangle_reachable(bvh, ref, "kd top 6 sibenik (every 16th triangle)", 16);
}

// Leaf boxes from somewhere else (here: a 3x2x2 grid over the bounds) work the same way.
TEST(KdTopBvh, GivenBoxesBecomeTheTop) {
  const Reference& ref = reference(vendored_file(kHorse));
  const Aabb box = bounds_of(ref.tris);
  std::vector<Aabb> boxes;
  const Vec3 e = box.extent();
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 2; ++j)
      for (int k = 0; k < 2; ++k) {
        Aabb cell = box;
        cell.lo = box.lo + Vec3{e.x * static_cast<float>(i) / 3, e.y * static_cast<float>(j) / 2,
                                e.z * static_cast<float>(k) / 2};
        cell.hi = {i == 2 ? box.hi.x : box.lo.x + e.x * static_cast<float>(i + 1) / 3,
                   j == 1 ? box.hi.y : box.lo.y + e.y * static_cast<float>(j + 1) / 2,
                   k == 1 ? box.hi.z : box.lo.z + e.z * static_cast<float>(k + 1) / 2};
        boxes.push_back(cell);
      }
  const std::vector<TopCell> cells = top_cells_from_boxes(boxes);
  EXPECT_EQ(cells.size(), 2 * boxes.size() - 1);
  const Bvh bvh = build_top_bvh(ref.tris, cells, LeafExpander::binned, BvhBuildOptions{});
  expect_every_triangle_reachable(bvh, ref, "grid top horse");
  expect_same_answers(ref.brute, answers_of_structure(bvh, ref.rays), ref.rays, "grid top horse");

  boxes.erase(boxes.begin());  // a hole: some triangles are in no cell
  EXPECT_THROW(
      build_top_bvh(ref.tris, top_cells_from_boxes(boxes), LeafExpander::binned, BvhBuildOptions{}),
      Error);
}

}  // namespace
}  // namespace splitray::test

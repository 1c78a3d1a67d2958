#pragma once
// `mpirun -np N splitray render`: the image as tiles handed out by rank 0 (a work queue:
// tiles differ in cost), every rank with its own copy of the scene and structure; rank 0
// assembles the tiles. Without mpirun the same code renders every tile in this process.
#include <vector>

#include "splitray/dist/work_queue.hpp"
#include "splitray/render/whitted.hpp"

namespace splitray::app {

struct DistRender {
  RenderResult result;  // rank 0: the assembled image (options.crop's pixels, or all)
  std::vector<dist::RankStats> ranks;
  std::size_t tiles = 0;
};

// Every rank calls it with the same arguments (the scene loaded on each).
DistRender render_distributed(const Scene& scene, const Camera& camera,
                              const RenderOptions& options, int tile_size);

// The tiles of `region`: tile_size x tile_size squares (smaller at its right and bottom
// edges), row by row.
std::vector<PixelRect> tile_rects(const PixelRect& region, int tile_size);

}  // namespace splitray::app

#pragma once
// `mpirun -np N splitray render`: the image as tiles handed out by rank 0 (a work queue:
// tiles differ in cost), every rank with its own copy of the scene and structure; rank 0
// assembles the tiles. Without mpirun the same code renders every tile in this process.
#include <string>
#include <vector>

#include "splitray/dist/work_queue.hpp"
#include "splitray/render/whitted.hpp"

namespace splitray::app {

struct DistRender {
  RenderResult result;  // rank 0: the assembled image (options.crop's pixels, or all)
  std::vector<dist::RankStats> ranks;
  std::size_t tiles = 0;
};

// Every rank calls it with the same arguments (the scene loaded on each). `mode` "hybrid":
// every rank renders through its own headless OpenGL context and hybrid renderer, the tiles
// are bands of tile_size rows over the whole width (each band is one GPU frame whose CPU pass
// traces the band only).
DistRender render_distributed(const Scene& scene, const Camera& camera,
                              const RenderOptions& options, int tile_size,
                              const std::string& mode = "whitted");

// The tiles of `region`: tile_size x tile_size squares (smaller at its right and bottom
// edges), row by row.
std::vector<PixelRect> tile_rects(const PixelRect& region, int tile_size);

}  // namespace splitray::app

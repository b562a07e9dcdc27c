// Level of detail for large static Gaussian sets (a lifted town has millions):
// the set cut into square spatial chunks (chunk_size metres in x and y, all z)
// with the bounds of their Gaussians' 3σ extents, and per chunk a coarse
// level of merged Gaussians; per view, the chunks outside the camera's
// frustum or beyond max_distance are left out, and those beyond
// coarse_distance drawn at the coarse level, before the renderer's per-frame
// sort (docs/stage3-lifting.md, "Level of detail").
//
// Coarse level: the chunk's Gaussians grouped by a merge_cell grid; each group
// becomes one Gaussian by moment matching with weights w = α·A (A = the
// product of the two largest σ: the footprint of a flat Gaussian):
//   μ = Σ w μᵢ / Σ w,  Σ = Σ w (Σᵢ + (μᵢ − μ)(μᵢ − μ)ᵀ) / Σ w,
//   SH = Σ w SHᵢ / Σ w,  α = min(0.99, Σ αᵢ Aᵢ / A(Σ)),
// scales and rotation from Σ's eigen-decomposition (Jacobi, right-handed).
// A group of one Gaussian is kept as it is.
// Frustum test: a chunk is out when all 8 corners of its bounds lie outside
// one plane of the view (near z = near_plane, the four sides widened by
// margin_px pixels); exact for the rasterizer's 3σ footprints up to its
// Jacobian linearisation, which the margin absorbs.
// Tests: tests/splat/test_gaussian_lod.cpp; benchmark: bench/bench_lod.cpp.
#pragma once

#include "render/camera.h"
#include "splat/gaussians.h"

#include <cstdint>
#include <vector>

namespace icube::splat {

struct GaussianChunkOptions {
  double chunk_size = 25.6;  // metres (x, y)
  double merge_cell = 0.8;   // metres: the coarse level's grouping grid
};

struct GaussianChunk {
  glm::dvec3 lo{0.0}, hi{0.0};  // bounds of the Gaussians' 3σ extents (largest σ in every direction)
  uint32_t first = 0, count = 0;                // in ChunkedGaussians::fine
  uint32_t coarse_first = 0, coarse_count = 0;  // in ChunkedGaussians::coarse
};

struct ChunkedGaussians {
  GaussianCloud fine;    // the input, reordered chunk by chunk (stable within a chunk)
  GaussianCloud coarse;  // the merged level, chunk by chunk
  std::vector<GaussianChunk> chunks;
  GaussianChunkOptions options;
};

ChunkedGaussians build_gaussian_chunks(const GaussianCloud& cloud, const GaussianChunkOptions& o = {});

// The whole set as one chunk in its own order, without a coarse level: for renderers that draw
// everything through LodGaussiansGpu (pick {0, fine}) and keep the host path's order exactly.
ChunkedGaussians single_chunk(GaussianCloud cloud);

// The moment-matched merge of Gaussians `idx` of `cloud` (see above), appended to `out`.
void merge_gaussians(const GaussianCloud& cloud, const std::vector<uint32_t>& idx, GaussianCloud& out);

struct LodOptions {
  double max_distance = 0.0;     // > 0: chunks farther than this (nearest point of their bounds) are left out
  double coarse_distance = 0.0;  // > 0: chunks farther than this are drawn at the coarse level
  bool frustum = true;
  double near_plane = 0.01;      // metres (the rasterizer's near cull is further)
  double margin_px = 16.0;
};

struct LodSelection {
  GaussianCloud cloud;
  size_t chunks_fine = 0, chunks_coarse = 0, chunks_out = 0;
};

// The chunks a view of `cam` draws and at which level, in chunk order.
struct ChunkPick {
  uint32_t chunk = 0;
  bool coarse = false;
  bool operator==(const ChunkPick&) const = default;
};
struct LodPicks {
  std::vector<ChunkPick> picks;
  size_t chunks_fine = 0, chunks_coarse = 0, chunks_out = 0;
};
LodPicks pick_chunks(const std::vector<GaussianChunk>& chunks, const render::Camera& cam, const LodOptions& o);

// The Gaussians a view of `cam` draws (pick_chunks' chunks, appended in chunk order).
LodSelection select_gaussians(const ChunkedGaussians& c, const render::Camera& cam, const LodOptions& o);

// Whether the box [lo, hi] lies wholly outside the view (see the frustum test above).
bool box_outside_view(const glm::dvec3& lo, const glm::dvec3& hi, const render::Camera& cam, double near_plane,
                      double margin_px);

}  // namespace icube::splat

// CPU reference of the tile-based Gaussian splatting rasterizer, exactly per
// ../shared/reference/splatting.md §1–3 (Inria's pipeline with the principal
// point honoured as in gsplat). The GPU path (rasterizer_gpu.h) reproduces it
// stage by stage; tests/splat/test_splat.cpp compares the two.
//
// Conventions:
// - Camera: OpenCV pinhole (fx, fy, cx, cy, W, H) and a camera-to-world pose
//   (x right, y down, z forward). means2d = (fx·x/z + cx, fy·y/z + cy); pixel
//   (u, v) is sampled at (u + o, v + o) with o = 0.5 (PixelConvention::Centre,
//   gsplat's convention, the default) or 0 (Integer, Inria's ndc2Pix).
// - Camera-relative coordinates: μ − camera position in double, then float.
// - Preprocess: cull z <= near or z > far; Σ₂ = J·W·Σ·Wᵀ·Jᵀ with x/z, y/z
//   clamped to [−(cx/fx + 0.3·tan), (W−cx)/fx + 0.3·tan] (tan = W/(2fx);
//   1.3·tan(fov/2) for a centred principal point), +eps2d (0.3 px²) on the
//   diagonal; antialiased: opacity ·= √max(2.5e-5, det(Σ₂)/det(Σ₂ + eps2d·I));
//   cull det <= 0 or any non-finite value; radius = ⌈3·√λ_max⌉ with
//   λ = mid ± √max(0.1, mid² − det); Inria's getRect (truncating, clamped to the
//   grid); cull empty rects; cull opacity < 1/255 (it can never pass the blend's
//   1/255 test). Colour = SH (degree 0–3) at normalize(μ − camera) + 0.5, max 0.
// - Binning: the tiles of the rect that the α-cut ellipse reaches (exact tile
//   culling, tile_row_span below: q(d) <= −2·ln(0.9/(255·o)) against the tile
//   grown by SPLAT_CULL_MARGIN px; tiles it skips cannot give any of their
//   pixels α >= 1/255, so the image equals binning the whole rect);
//   key = tile_id << 32 | float bits of z, emitted in Gaussian order
//   and stably sorted; ranges[tile] = [start, end) into the sorted list.
// - Blend, front to back per pixel: power = −½(a'dx² + c'dy²) − b'dxdy, skip
//   power > 0; α = min(0.99, o·e^power), skip α < 1/255; stop (without this
//   Gaussian) when T·(1−α) < 1e-4. Outputs C + T·background, alpha = 1 − T,
//   expected depth Σwz/Σw (0 where Σw = 0), median depth = z of the Gaussian
//   after which T <= 0.5 first (0 if never).
// - Sky: SplatOptions::sky replaces the constant background by sky(d) for the
//   pixel's world ray direction d (engine/splat/sky.h): C + T·sky(d).
#pragma once

#include "render/camera.h"
#include "shared/splat_params.h"
#include "splat/gaussians.h"
#include "splat/splat_frame.h"

#include <glm/glm.hpp>

#include <cstdint>
#include <vector>

namespace icube::splat {

// Tile rect [x0, x1) × [y0, y1) of a projected Gaussian.
struct TileRect {
  uint32_t x0 = 0, y0 = 0, x1 = 0, y1 = 0;
  uint32_t area() const { return (x1 - x0) * (y1 - y0); }
};
TileRect tile_rect(float mean_x, float mean_y, float radius, uint32_t grid_x, uint32_t grid_y);

// ln(0.9 / (255·opacity)): power below it cannot give α >= 1/255 (10 % margin); the blend
// record's log_cut and the culling threshold.
float splat_log_cut(float opacity);
// Exact tile culling: [x0, x1) of the tiles in row `ty` of rect `r` that the α-cut ellipse of
// `g` (conic, mean, log_cut = splat_log_cut(opacity)) reaches; x0 == x1 when none. Same float
// operations as shaders/splat/tiles.glsl, so GPU and CPU tile lists agree.
void tile_row_span(const shader::SplatProjected& g, float log_cut, const TileRect& r, uint32_t ty, uint32_t& x0,
                   uint32_t& x1);
// Tile instances of a projected Gaussian under `rule` (0 when culled).
enum class TileRule { Ellipse, Rect };  // Rect: the whole getRect rect (the pre-culling rule)
uint32_t tile_count(const shader::SplatProjected& g, uint32_t grid_x, uint32_t grid_y,
                    TileRule rule = TileRule::Ellipse);

// Preprocesses one Gaussian at camera-relative position `d` (metres, world axes).
shader::SplatProjected project_gaussian(const glm::vec3& d, float opacity, const float cov[6], const float* sh,
                                        uint32_t sh_degree, const shader::SplatPreprocessParams& f);
// SH colour (+0.5, clamped at 0) for unit direction `dir`.
glm::vec3 sh_color(const float* sh, uint32_t degree, const glm::vec3& dir);

struct TileBins {
  std::vector<uint64_t> keys;      // sorted
  std::vector<uint32_t> values;    // Gaussian index per key
  std::vector<uint32_t> ranges;    // 2 per tile: [start, end)
};

std::vector<shader::SplatProjected> preprocess_cpu(const GaussianCloud& cloud, const render::Camera& cam,
                                                   const SplatOptions& opts);
// Keys tile << 32 | depth_sort_key(depth, depth_key_bits) (splat_frame.h), stably sorted.
TileBins bin_cpu(const std::vector<shader::SplatProjected>& proj, uint32_t grid_x, uint32_t grid_y,
                 TileRule rule = TileRule::Ellipse, uint32_t depth_key_bits = 32);
SplatImage blend_cpu(const std::vector<shader::SplatProjected>& proj, const TileBins& bins, const render::Camera& cam,
                     const SplatOptions& opts);
SplatImage render_cpu(const GaussianCloud& cloud, const render::Camera& cam, const SplatOptions& opts);

}  // namespace icube::splat

// Records and push constants of the LiDAR-on-Gaussians caster
// (shaders/splat/lidar_bin.comp, splat/lidar_duplicate.comp,
// splat/lidar_cast.comp; host module engine/splat/lidar_gaussians_gpu.h, CPU
// reference engine/splat/lidar_gaussians_cpu.h, where the maths is written
// out). Shared by GLSL and C++.
//
// Per Gaussian (SplatLidarGaussian, 64 bytes): the centre relative to the
// scene origin, the activated opacity, the whitening matrix W = diag(1/s)·Rᵀ
// (rows, so Σ⁻¹ = WᵀW and m' = W·m is the offset in units of σ along the
// Gaussian's axes), the per-Gaussian intensity and the cut radius r_cut (the
// largest distance from the centre at which the Gaussian can still reach
// α >= 1/255, with a safety margin; 0 = never visible).
// Per ray (SplatLidarHit, 32 bytes): the composite of the Gaussians along it.
#ifndef ICUBE_SPLAT_LIDAR_PARAMS_H
#define ICUBE_SPLAT_LIDAR_PARAMS_H
#include "gpu_types.h"

// Bins: tiles of SPLAT_LIDAR_TILE_ROWS rings x SPLAT_LIDAR_TILE_COLS columns
// of the range image; one cast workgroup (64 invocations) per tile.
#define SPLAT_LIDAR_TILE_ROWS 4
#define SPLAT_LIDAR_TILE_COLS 16
#define SPLAT_LIDAR_TILE_RAYS 64
// Per-ray candidate slots and pass limit of the cast kernel (see splat/lidar_cast.comp). K = 8: each
// insertion and pop moves O(K) registers; K = 16 (with indexed arrays) ran ~2x slower on lavapipe.
#define SPLAT_LIDAR_K 8
#define SPLAT_LIDAR_MAX_PASSES 64u

// Gaussian records are bound as up to SPLAT_LIDAR_WINDOWS storage windows of window_n records each
// (the last may hold fewer), so a set larger than one binding (lavapipe: 128 MiB = 2 M records) casts.
#define SPLAT_LIDAR_WINDOWS 4

#define SPLAT_LIDAR_FLAG_OVERFLOW 1u  // more than K pending contributors: the ray took several passes (exact)
#define SPLAT_LIDAR_FLAG_STOPPED 2u   // transmittance reached the 1e-4 stop rule
#define SPLAT_LIDAR_FLAG_MEDIAN 4u    // T fell to <= 0.5: t_median is set
#define SPLAT_LIDAR_FLAG_TRUNCATED 8u // the pass limit was reached: contributors beyond it are missing

ICUBE_SHADER_NAMESPACE_BEGIN

struct SplatLidarGaussian {
  float px, py, pz;  // metres, relative to the scene origin
  float opacity;     // sigmoid(raw)
  float w00, w01, w02;
  float intensity;  // [0, 1]
  float w10, w11, w12;
  float r_cut;  // metres; 0 = culled (opacity < 1/255)
  float w20, w21, w22;
  float pad;
};

struct SplatLidarHit {
  float alpha;       // 1 - T: accumulated opacity
  float t_expected;  // Σ w t* / Σ w (0 when nothing contributed)
  float t_median;    // t* where T first fell to <= 0.5 (SPLAT_LIDAR_FLAG_MEDIAN; else 0)
  float intensity;   // Σ w I / Σ w
  uint count;        // contributing Gaussians (α >= 1/255 with t* in range), composited
  uint flags;        // SPLAT_LIDAR_FLAG_*
  float pad0, pad1;
};

// One set of push constants for the three kernels (each uses what it needs).
struct SplatLidarParams {
  uint n;  // Gaussians (bin, duplicate) or unused (cast)
  uint beams, columns;
  uint tiles_x, tiles_y;
  float min_range, max_range;
  float start_azimuth;  // radians, column 0's leading edge (lidar_model.h)
  float s00, s01, s02;  // sensor-to-world rotation, row-major: d_world = S · d_sensor
  float s10, s11, s12;
  float s20, s21, s22;
  float ox, oy, oz;  // sensor origin relative to the scene origin
  uint window_n;     // Gaussian records per storage window (splat/lidar_gaussians.glsl)
  // cast: a batch of tile rows from tile_row_base; the dirs and hits bindings start at rays dirs_base and
  // hits_base (a sweep's hits over one storage binding run in batches of whole tile rows).
  uint tile_row_base, dirs_base, hits_base;
};

ICUBE_SHADER_NAMESPACE_END

ICUBE_CHECK_SIZE(SplatLidarGaussian, 64);
ICUBE_CHECK_LAYOUT(SplatLidarGaussian, opacity, 12);
ICUBE_CHECK_LAYOUT(SplatLidarGaussian, w00, 16);
ICUBE_CHECK_LAYOUT(SplatLidarGaussian, intensity, 28);
ICUBE_CHECK_LAYOUT(SplatLidarGaussian, r_cut, 44);
ICUBE_CHECK_LAYOUT(SplatLidarGaussian, w20, 48);
ICUBE_CHECK_SIZE(SplatLidarHit, 32);
ICUBE_CHECK_LAYOUT(SplatLidarHit, count, 16);
ICUBE_CHECK_SIZE(SplatLidarParams, 96);
ICUBE_CHECK_LAYOUT(SplatLidarParams, tile_row_base, 84);
ICUBE_CHECK_LAYOUT(SplatLidarParams, start_azimuth, 28);
ICUBE_CHECK_LAYOUT(SplatLidarParams, s00, 32);
ICUBE_CHECK_LAYOUT(SplatLidarParams, ox, 68);
ICUBE_CHECK_LAYOUT(SplatLidarParams, window_n, 80);

#endif

// LiDAR on Gaussians, CPU reference: spinning-LiDAR rays (the model of
// render/lidar/lidar_model.h: rings, columns, azimuth/elevation conventions,
// ray index = ring · columns + column) cast against a 3D Gaussian set, every
// Gaussian for every ray, in double precision, sorted per ray. The GPU module
// (lidar_gaussians_gpu.h) computes the same in float with binning.
//
// Per ray o + t·d (unit d, world frame) and Gaussian (μ, Σ = R·diag(s²)·Rᵀ):
//  - Whitening W = diag(1/s)·Rᵀ, so Σ⁻¹ = WᵀW. With m = μ − o (relative to the
//    sensor, double: a scene 100 km from the origin casts the same), the
//    whitened offset m' = W·m and direction d' = W·d.
//  - Peak along the ray: t* = dᵀΣ⁻¹m / dᵀΣ⁻¹d = (d'·m') / (d'·d').
//  - Response G = exp(−½ q²) with q² = mᵀΣ⁻¹m − (dᵀΣ⁻¹m)²/(dᵀΣ⁻¹d), written
//    without the cancellation as q² = |m' × d'|² / |d'|² (Lagrange's identity).
//  - α = min(0.99, opacity · G); the Gaussian contributes when α >= 1/255 and
//    min_range <= t* <= max_range (t* outside is skipped, as is the part of a
//    Gaussian behind the sensor: t* < min_range).
//  - Scales are clamped below at kLidarMinScale (0.1 µm) so W stays finite in
//    float; nothing measurable changes.
// Compositing: contributors in increasing t* (ties by Gaussian index), front
// to back with the splat blend's rules (rasterizer_cpu.h): w = α·T, stop
// before a Gaussian that would take T·(1 − α) below 1e-4 (it and everything
// behind are dropped), T ← T·(1 − α).
//  - alpha = 1 − T; expected range = Σ w t* / Σ w; median range = the t* at
//    which T first falls to <= 0.5 (SPLAT_LIDAR_FLAG_MEDIAN);
//  - intensity = Σ w I / Σ w with the per-Gaussian intensity I of
//    lidar_gaussian_intensity: the luminance (Rec. 709: 0.2126 R + 0.7152 G
//    + 0.0722 B) of the view-independent DC colour max(0, C0·f_dc + 0.5),
//    clamped to [0, 1]. GaussianCloud keeps no extra .ply attributes, so a
//    `reflectivity` property is not read; callers may pass their own I.
// Returns (lidar_scan_from_gaussian_hits): a ray returns when alpha >=
// alpha_threshold (default 0.5: at least half the beam's energy is blocked,
// which is also when the median range exists); range = the median range
// (default; the first surface, robust to floaters behind it) or the expected
// range (LidarRangeMode::Expected); a median that does not exist (threshold
// below 0.5) falls back to the expected range. Class and instance are 0
// (Gaussians carry no semantics); point and frames as lidar_scan.h.
// Cut radius: α >= 1/255 needs q² <= 2·ln(255·opacity), and q >= |x − μ| /
// s_max, so only points within r_cut = s_max · sqrt(2 ln(255·opacity)) of μ
// matter (no Gaussian with opacity < 1/255 ever contributes). The peak point
// o + t*·d lies within r_cut of μ, hence t* >= |m| − r_cut: the GPU kernel
// sorts by that bound (lidar_gaussians_gpu.h).
// Tests: tests/splat/test_lidar_gaussians.cpp.
#pragma once

#include "render/lidar/lidar_model.h"
#include "render/lidar/lidar_scan.h"
#include "splat/gaussians.h"

#include "shared/splat_lidar_params.h"

#include <glm/glm.hpp>

#include <cstdint>
#include <vector>

namespace icube::splat {

inline constexpr double kLidarMinScale = 1e-7;        // metres
inline constexpr double kLidarMinAlpha = 1.0 / 255.0;  // the splat blend's skip threshold
inline constexpr double kLidarMaxAlpha = 0.99;
inline constexpr double kLidarStopT = 1e-4;

enum class LidarRangeMode { Median, Expected };

struct LidarGaussianOptions {
  double alpha_threshold = 0.5;  // return when 1 − T >= this; (0, 1]
  LidarRangeMode range = LidarRangeMode::Median;
};

// One Gaussian prepared for ray evaluation (double).
struct LidarGaussian {
  glm::dvec3 mean{0.0};
  glm::dmat3 W{1.0};  // whitening; W[c][r] is column c (glm), apply as W * v
  double opacity = 0.0;
  double intensity = 0.0;
  double r_cut = 0.0;  // metres (0: never contributes)
};

LidarGaussian lidar_gaussian(const glm::dvec3& mean, const glm::vec3& scale, const glm::vec4& q_wxyz, float opacity,
                             float intensity);
// The Gaussians of `cloud` that can give a sensor at `sensor` a return within `max_range`: those
// with |μ − sensor| − r_cut <= max_range (t* >= |m| − r_cut, see the header comment; r_cut
// taken 1 % + 1 mm larger for rounding), in their order. The others never contribute, so a
// scan of the subset is the scan of the whole set, and a set over the GPU caster's limit fits.
GaussianCloud lidar_range_subset(const GaussianCloud& cloud, const glm::dvec3& sensor, double max_range);

// Per-Gaussian intensity (see the header comment); size() values in [0, 1].
std::vector<float> lidar_gaussian_intensity(const GaussianCloud& cloud);

struct RayGaussianResponse {
  double t = 0.0;      // t* (metres along the unit direction)
  double q2 = 0.0;     // squared Mahalanobis distance of the peak point
  double G = 0.0;      // exp(−½ q²)
  double alpha = 0.0;  // min(0.99, opacity · G)
};
// `m` = μ − o (world frame, relative to the ray origin), `d` unit.
RayGaussianResponse ray_gaussian_response(const LidarGaussian& g, const glm::dvec3& m, const glm::dvec3& d);

// All rays of one sweep from the sensor pose `sensor_to_world` (FLU sensor
// axes, as lidar_scan.h), one SplatLidarHit per ray in ray order. `rays`: ray
// indices to cast (empty = all; the others stay zero). `threads`: worker
// threads over rays (0 = hardware concurrency). Throws std::invalid_argument
// when `intensity` has the wrong size or the model is invalid.
std::vector<shader::SplatLidarHit> cast_lidar_gaussians_cpu(const GaussianCloud& cloud,
                                                           const std::vector<float>& intensity,
                                                           const render::LidarModel& model,
                                                           const glm::dmat4& sensor_to_world, unsigned threads = 1,
                                                           const std::vector<uint32_t>& rays = {});

// Hits (ray order, sensor-frame unit directions `dirs` = lidar_directions(model)) to returns and the range image.
// Throws std::invalid_argument on a size mismatch or a threshold outside (0, 1].
render::LidarScan lidar_scan_from_gaussian_hits(const render::LidarModel& model, const std::vector<glm::dvec3>& dirs,
                                                const glm::dmat4& sensor_to_world,
                                                const std::vector<shader::SplatLidarHit>& hits,
                                                const LidarGaussianOptions& opts);

}  // namespace icube::splat

// `icube eval PACKAGE` (docs/evaluation.md): three measures of a package
// written by `icube generate`.
//
// Novel views. The package's Gaussians (static set, dynamic objects at the
// frame's poses, the fitted sky) rendered at frames NOT used for lifting and
// compared with the appearance frames (heldout_render.h): PSNR and SSIM over
// the static pixels, PSNR over the moving cars' pixels. One row per offset o
// of `offsets` (frames T + o for every key frame T, when T + o exists and is
// held out; a T + o that is itself a key frame is counted as skipped), and a
// row over up to `max_heldout` held-out frames spread evenly.
//
// Map alignment. Road edges and lane lines of the scene's map, sampled every
// 0.25 m and moved by the median height offset to the world's ground (the top
// face of the first ground-class voxel of each sample's column within 2 m: a
// map's heights and the prior's road surface can differ), projected into each frame's camera (z in [0.5, max_map_depth] m),
// kept where the guidance depth buffer shows them unoccluded (z <= depth +
// max(0.5 m, 5 %)), against the guidance semantic buffer's palette entry 5
// (CURB and LANE_MARKER, conventions §4): map → buffer is the distance in
// pixels from each projected sample to the nearest such pixel (exact distance
// transform), per layer; paint → map the ground-plane distance in metres from
// each such pixel's 3-D point (its depth along its ray, depth <=
// max_map_depth) to the nearest road edge or lane line, 0 inside a crosswalk,
// capped at 6 m. Dashed lines put their gaps' samples a dash-gap away from
// paint, which shows in map → buffer and not in paint → map; curbs lie up to
// 0.3 m (their band) plus half a voxel beside their edge.
//
// LiDAR agreement. The same sweeps (the scene's ego track at frames' scene
// times, `lidar` model) cast against the voxel world with the frame's cars
// (render/lidar) and against the package's Gaussians placed at the frame
// (splat/lidar_gaussians_gpu.h); per ray that returns in both, |Δrange|;
// counts of rays returning in only one. Over all rays and over the rays
// inside the frame's camera view (where the Gaussians were lifted).
// Tests: tests/lift/test_package_eval.cpp.
#pragma once

#include "gpu/context.h"
#include "lift/heldout_render.h"
#include "render/lidar/lidar_model.h"
#include "scene/scene.h"

#include <functional>
#include <string>
#include <vector>

namespace icube::lift {

struct PackageEvalOptions {
  std::vector<int> offsets = {5, 10};
  size_t max_heldout = 8;     // frames of the "held-out" row (evenly spread); 0: none
  double max_map_depth = 40.0;
  double map_tolerance_px = 2.0;  // map → buffer
  double paint_tolerance_m = 0.5;  // paint → map
  size_t lidar_frames = 3;    // sweeps (evenly spread over the frames with a scene time); 0: no LiDAR
  render::LidarModel lidar = render::lidar_preset("waymo-top");
  std::function<void(const char* stage, size_t done, size_t total)> progress;
};

struct NovelViewRow {
  std::string label;  // "T+5", "held-out"
  int offset = 0;     // 0 for the held-out row
  size_t frames = 0, skipped_key_frames = 0;
  double psnr = 0.0, ssim = 0.0, psnr_dynamic = 0.0;  // means over the frames (dynamic: over frames with cars)
  size_t dynamic_frames = 0;
};

struct DistanceStats {
  size_t samples = 0;
  double median = 0.0, p90 = 0.0, mean = 0.0, within = 0.0;  // within: share <= map_tolerance_px
};

struct MapAlignment {
  size_t frames = 0;
  DistanceStats road_edges, lane_lines;  // map → buffer
  DistanceStats marking_to_map;          // paint → map, metres
  double ground_offset_median_signed = 0.0;  // world ground − map height, applied to every sample
  DistanceStats ground_offset;               // |offset − the median| per sample, metres (the spread)
};

struct LidarStats {
  uint64_t rays = 0, both = 0, voxel_only = 0, gaussian_only = 0;
  double p50 = 0.0, p90 = 0.0, p99 = 0.0, mean_signed = 0.0;  // metres, Gaussians − voxels, over `both`
};

struct LidarAgreement {
  size_t frames = 0;
  LidarStats all, in_view;
  std::string note;  // why there is no LiDAR figure, when there is none
};

struct PackageEval {
  std::string package;
  size_t frames = 0;
  std::vector<size_t> key_frames;
  std::vector<NovelViewRow> novel;
  std::vector<EvalFrame> rendered;  // every frame evaluated, in frame order
  MapAlignment map;
  LidarAgreement lidar;
  std::vector<uint8_t> map_overlay;  // one frame's semantic buffer with the projected samples (W·H·3)
  size_t map_overlay_frame = 0;
  uint32_t width = 0, height = 0;
  double seconds_novel = 0.0, seconds_map = 0.0, seconds_lidar = 0.0;
};

// `scene`: the scene the package was generated from (its map, cars and ego track).
// Throws scene::InputError naming the file for a partial or malformed package.
PackageEval evaluate_package(gpu::Context& ctx, const std::string& package, const scene::Scene& scene,
                             const PackageEvalOptions& o);

// DIR/eval.json (every figure and per-frame row) and DIR/eval.png (per evaluated frame, up to
// 4: reference | rendered | |error| x4; then the map overlay). Files written atomically.
void write_package_eval(const std::string& dir, const PackageEval& e, const PackageEvalOptions& o);

// The measures' percentiles: nearest-rank on a sorted copy (0 for an empty set).
DistanceStats distance_stats(std::vector<double> values, double tolerance);

}  // namespace icube::lift

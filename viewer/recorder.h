// Trajectory recording for the viewer (CPU only; library icube_viewer_core).
//
// A pass is a list of recorded camera poses (OpenCV camera-to-world, the
// scene's world frame, as engine/render/buffers/trajectory.h reads them):
// keyframes added by hand, or samples taken every 1/rate_hz seconds of
// simulated time while continuous recording is on (10 Hz, the Waymo rate).
// end_pass() closes the current pass (>= 2 poses) and starts the next.
// Interpolation to N frames (93 = InfiniCube's video length by default):
// frames are spaced evenly in a path parameter that grows with distance
// travelled plus turned angle (1 m per radian), so a pass recorded at varying
// speed becomes a constant-speed camera and in-place turns still interpolate;
// between the two bracketing poses, position lerp and rotation slerp.
// (InfiniCube blends more than two keys with Gaussian weights, which smooths
// but misses the last key; we pass through every key.)
// Files: .npy float32 [P,N,4,4] (multi_pass_camera_poses.npy) and one JSON
// per pass ({"format": "icube-trajectory", "version": 1, "poses", "camera"}).
// Tests: tests/viewer/test_viewer.cpp.
#pragma once

#include "render/camera.h"
#include "world/voxel_grid.h"

#include <glm/glm.hpp>

#include <optional>
#include <string>
#include <vector>

namespace icube::viewer {

inline constexpr int kDefaultInterpolatedFrames = 93;

using Pass = std::vector<glm::dmat4>;

class Recorder {
 public:
  double rate_hz = 10.0;

  void start_continuous(double t);
  void stop_continuous() { continuous_ = false; }
  bool continuous() const { return continuous_; }
  // Called every frame with the recorded camera's pose; samples at rate_hz while continuous.
  void update(double t, const glm::dmat4& c2w);
  void add_keyframe(const glm::dmat4& c2w) { current_.push_back(c2w); }
  // Closes the current pass; false (and the pass is kept open) when it has fewer than 2 poses.
  bool end_pass();
  void discard_current() { current_.clear(); }
  void clear();

  const Pass& current() const { return current_; }
  const std::vector<Pass>& passes() const { return passes_; }
  void set_passes(std::vector<Pass> p) { passes_ = std::move(p); }

 private:
  bool continuous_ = false;
  double next_sample_t_ = 0.0;
  Pass current_;
  std::vector<Pass> passes_;
};

// The path parameter of each pose: cumulative distance + turned angle (radians, 1 m each).
std::vector<double> path_parameter(const Pass& keys);
// N poses along the keys (see above). One key: N copies. Throws std::invalid_argument for n < 1 or no keys.
Pass interpolate_pass(const Pass& keys, int n);

// Writes float32 [P,N,4,4] (all passes must have the same length). Atomic.
void save_passes_npy(const std::string& path, const std::vector<Pass>& passes);
// One pass as the project's trajectory JSON, with the target camera's intrinsics when given.
void save_pass_json(const std::string& path, const Pass& pass, const std::optional<render::PinholeIntrinsics>& camera);
// "out/run.npy" -> "out/run_pass1.json"
std::string pass_json_path(const std::string& npy_path, size_t pass);
// Every pass of an .npy or JSON trajectory file (render::load_trajectory).
std::vector<Pass> load_passes(const std::string& path);

// Checks on recorded passes, as a person would look at them (tests and icube-view --verify):
//  - shape: `passes` passes (0 = any >= 1) of `frames` poses each;
//  - progress: every step moves forwards along the camera's viewing axis
//    (OpenCV +z; >= -1 cm) and the pass covers at least min_travel metres;
//  - heights: when a grid is given, every camera is camera_height (+- tol) above the ground under it.
// Returns one line per failure (empty = all good).
struct PassCheckOptions {
  size_t passes = 0;
  size_t frames = kDefaultInterpolatedFrames;
  double min_travel = 5.0;
  double camera_height = 2.0;
  double height_tolerance = 0.4;
};
std::vector<std::string> check_passes(const std::vector<Pass>& passes, const world::VoxelGrid* grid,
                                      const PassCheckOptions& opts);

}  // namespace icube::viewer

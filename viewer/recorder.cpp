// Trajectory recording, interpolation and files; see recorder.h.
#include "recorder.h"

#include "vehicle.h"

#include "render/buffers/trajectory.h"
#include "scene/atomic_file.h"
#include "world/npy.h"

#include <glm/gtc/quaternion.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace icube::viewer {

void Recorder::start_continuous(double t) {
  continuous_ = true;
  next_sample_t_ = t;
}

void Recorder::update(double t, const glm::dmat4& c2w) {
  if (!continuous_) return;
  if (t + 1e-9 >= next_sample_t_) {
    current_.push_back(c2w);
    // Keep a fixed 10 Hz grid (no drift with uneven frame times); skip missed slots.
    const double period = 1.0 / rate_hz;
    next_sample_t_ += period;
    if (next_sample_t_ <= t) next_sample_t_ = t + period;
  }
}

bool Recorder::end_pass() {
  if (current_.size() < 2) return false;
  passes_.push_back(std::move(current_));
  current_.clear();
  continuous_ = false;
  return true;
}

void Recorder::clear() {
  current_.clear();
  passes_.clear();
  continuous_ = false;
}

std::vector<double> path_parameter(const Pass& keys) {
  std::vector<double> s(keys.size(), 0.0);
  for (size_t i = 1; i < keys.size(); ++i) {
    const double dist = glm::length(glm::dvec3(keys[i][3]) - glm::dvec3(keys[i - 1][3]));
    const glm::dquat a = glm::quat_cast(glm::dmat3(keys[i - 1])), b = glm::quat_cast(glm::dmat3(keys[i]));
    const double c = std::min(1.0, std::fabs(glm::dot(a, b)));
    const double angle = 2.0 * std::acos(c);
    s[i] = s[i - 1] + dist + angle;
  }
  return s;
}

Pass interpolate_pass(const Pass& keys, int n) {
  if (n < 1) throw std::invalid_argument("interpolate_pass: need at least one frame");
  if (keys.empty()) throw std::invalid_argument("interpolate_pass: no poses");
  if (keys.size() == 1) return Pass(static_cast<size_t>(n), keys[0]);
  std::vector<double> s = path_parameter(keys);
  if (!(s.back() > 1e-9))  // nothing moved: interpolate by index
    for (size_t i = 0; i < s.size(); ++i) s[i] = static_cast<double>(i);
  Pass out;
  out.reserve(static_cast<size_t>(n));
  size_t seg = 0;
  for (int i = 0; i < n; ++i) {
    const double target = n == 1 ? 0.0 : s.back() * i / (n - 1);
    while (seg + 2 < s.size() && s[seg + 1] < target) ++seg;
    const double len = s[seg + 1] - s[seg];
    const double a = len > 0.0 ? std::clamp((target - s[seg]) / len, 0.0, 1.0) : 0.0;
    const glm::dmat4& A = keys[seg];
    const glm::dmat4& B = keys[seg + 1];
    const glm::dquat q = glm::slerp(glm::quat_cast(glm::dmat3(A)), glm::quat_cast(glm::dmat3(B)), a);
    glm::dmat4 m(glm::mat3_cast(glm::normalize(q)));
    m[3] = glm::dvec4(glm::mix(glm::dvec3(A[3]), glm::dvec3(B[3]), a), 1.0);
    out.push_back(m);
  }
  return out;
}

void save_passes_npy(const std::string& path, const std::vector<Pass>& passes) {
  if (passes.empty()) throw std::invalid_argument("save: no passes recorded");
  const size_t n = passes[0].size();
  std::vector<float> v;
  v.reserve(passes.size() * n * 16);
  for (const Pass& p : passes) {
    if (p.size() != n) throw std::invalid_argument("save: passes differ in length (interpolate them first)");
    for (const glm::dmat4& m : p)
      for (int r = 0; r < 4; ++r)
        for (int c = 0; c < 4; ++c) v.push_back(static_cast<float>(m[c][r]));
  }
  world::write_npy(path, world::NpyArray::make<float>({passes.size(), n, 4, 4}, v));
}

void save_pass_json(const std::string& path, const Pass& pass, const std::optional<render::PinholeIntrinsics>& camera) {
  scene::write_file_atomic(path, render::trajectory_json(pass, camera));
}

std::string pass_json_path(const std::string& npy_path, size_t pass) {
  std::string stem = npy_path;
  if (stem.size() > 4 && stem.compare(stem.size() - 4, 4, ".npy") == 0) stem.resize(stem.size() - 4);
  return stem + "_pass" + std::to_string(pass) + ".json";
}

std::vector<Pass> load_passes(const std::string& path) {
  const render::TrajectoryFile f = render::load_trajectory(path, 0);
  std::vector<Pass> out;
  for (const render::Trajectory& t : f.passes) out.push_back(t.c2w);
  return out;
}

std::vector<std::string> check_passes(const std::vector<Pass>& passes, const world::VoxelGrid* grid,
                                      const PassCheckOptions& opts) {
  std::vector<std::string> bad;
  if (passes.empty() || (opts.passes && passes.size() != opts.passes))
    bad.push_back("expected " + std::to_string(opts.passes) + " passes, found " + std::to_string(passes.size()));
  for (size_t p = 0; p < passes.size(); ++p) {
    const Pass& pass = passes[p];
    const std::string name = "pass " + std::to_string(p) + ": ";
    if (opts.frames && pass.size() != opts.frames)
      bad.push_back(name + std::to_string(pass.size()) + " poses, expected " + std::to_string(opts.frames));
    if (pass.empty()) continue;
    for (size_t i = 1; i < pass.size(); ++i) {
      const glm::dvec3 step = glm::dvec3(pass[i][3]) - glm::dvec3(pass[i - 1][3]);
      const double along = glm::dot(step, glm::dvec3(pass[i - 1][2]));
      if (along < -0.01) {
        bad.push_back(name + "step " + std::to_string(i) + " goes backwards by " + std::to_string(-along) + " m");
        break;
      }
    }
    const double travel = glm::length(glm::dvec3(pass.back()[3]) - glm::dvec3(pass.front()[3]));
    if (travel < opts.min_travel) bad.push_back(name + "travels only " + std::to_string(travel) + " m");
    if (grid) {
      for (size_t i = 0; i < pass.size(); ++i) {
        const glm::dvec3 c(pass[i][3]);
        const auto g = ground_height(*grid, c.x, c.y, c.z, 10.0);
        const double above = g ? c.z - *g : -1.0;
        if (!g || std::fabs(above - opts.camera_height) > opts.height_tolerance) {
          bad.push_back(name + "pose " + std::to_string(i) + (g ? " is " + std::to_string(above) + " m above the ground"
                                                                 : " has no ground below"));
          break;
        }
      }
    }
  }
  return bad;
}

}  // namespace icube::viewer

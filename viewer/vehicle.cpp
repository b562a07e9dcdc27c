// The viewer's car and cameras; see vehicle.h.
#include "vehicle.h"

#include "scene/frames.h"

#include <algorithm>
#include <cmath>

namespace icube::viewer {

namespace {

// Classes the car can stand on or bump into; people, vehicles, bikes, poles and signs are passed through.
bool is_solid_ground(uint8_t c) { return c >= 14; }

constexpr double kMaxClimb = 0.6;  // m per step: higher ground in front of the car blocks it

glm::dmat4 flu_frame(const glm::dvec3& forward, const glm::dvec3& left, const glm::dvec3& up, const glm::dvec3& p) {
  glm::dmat4 m(1.0);
  m[0] = glm::dvec4(forward, 0.0);
  m[1] = glm::dvec4(left, 0.0);
  m[2] = glm::dvec4(up, 0.0);
  m[3] = glm::dvec4(p, 1.0);
  return m;
}

}  // namespace

std::optional<double> ground_height(const world::VoxelGrid& grid, double x, double y, double z_from, double max_drop) {
  const glm::ivec3 top = grid.world_to_ijk({x, y, z_from});
  const int steps = static_cast<int>(std::ceil(max_drop / grid.voxel_size()));
  for (int k = 0; k <= steps; ++k) {
    const glm::ivec3 ijk{top.x, top.y, top.z - k};
    const uint8_t c = grid.get(ijk).class_id;
    if (c != 0 && is_solid_ground(c)) return grid.origin().z + (ijk.z + 1) * grid.voxel_size();
  }
  return std::nullopt;
}

void step_vehicle(VehicleState& s, const VehicleInput& in, double dt, const VehicleLimits& lim,
                  const world::VoxelGrid* grid, const GroundOptions& ground) {
  if (!(dt > 0.0)) return;
  const double throttle = std::clamp(in.throttle, 0.0, 1.0), brake = std::clamp(in.brake, 0.0, 1.0);
  // Steering: rate-limited towards the input, limited further at speed by the lateral acceleration.
  const double v2 = s.speed * s.speed;
  const double steer_lim = v2 > 1e-6 ? std::min(lim.max_steer, std::atan(lim.wheelbase * lim.max_lateral / v2)) : lim.max_steer;
  const double target = std::clamp(in.steer, -1.0, 1.0) * steer_lim;
  const double ds = std::clamp(target - s.steer, -lim.steer_rate * dt, lim.steer_rate * dt);
  s.steer = std::clamp(s.steer + ds, -steer_lim, steer_lim);

  // Longitudinal: forward gear, or reverse (brake at a standstill engages it, throttle leaves it).
  if (!s.reversing && std::fabs(s.speed) < 0.1 && brake > 0.5 && throttle < 0.1) s.reversing = true;
  if (s.reversing && throttle > 0.1 && s.speed > -0.1) s.reversing = false;
  const double resist = lim.rolling + lim.drag * v2;
  if (!s.reversing) {
    const double a = throttle * lim.max_accel - brake * lim.max_brake - (throttle > 0.0 ? lim.drag * v2 : resist);
    s.speed = std::clamp(s.speed + a * dt, 0.0, lim.max_speed);
  } else {
    const double a = -brake * lim.max_accel + throttle * lim.max_brake + (brake > 0.0 ? 0.0 : resist);
    s.speed = std::clamp(s.speed + a * dt, -lim.max_reverse, 0.0);
  }

  // Bicycle kinematics about the rear axle (midpoint heading).
  const double yaw_rate = s.speed * std::tan(s.steer) / lim.wheelbase;
  const double yaw_mid = s.yaw + 0.5 * yaw_rate * dt;
  VehicleState next = s;
  next.position.x += s.speed * std::cos(yaw_mid) * dt;
  next.position.y += s.speed * std::sin(yaw_mid) * dt;
  next.yaw = scene::wrap_angle(s.yaw + yaw_rate * dt);

  if (ground.zero_height) {
    next.position.z = ground.zero_z;
    next.pitch = 0.0;
  } else if (ground.follow && grid) {
    const auto hr = ground_height(*grid, next.position.x, next.position.y, s.position.z + ground.step_height);
    if (hr && *hr > s.position.z + kMaxClimb) {  // a wall: stop where we are
      s.speed = 0.0;
      return;
    }
    if (hr) next.position.z = *hr;
    const glm::dvec2 f = glm::dvec2(next.position) + lim.wheelbase * glm::dvec2(std::cos(next.yaw), std::sin(next.yaw));
    const auto hf = ground_height(*grid, f.x, f.y, next.position.z + ground.step_height);
    next.pitch = hf ? std::atan2(*hf - next.position.z, lim.wheelbase) : 0.0;
  }
  next.odometer += std::fabs(s.speed) * dt;
  s = next;
}

bool settle_vehicle(VehicleState& s, const VehicleLimits& lim, const world::VoxelGrid& grid,
                    const GroundOptions& ground, double search_from_z) {
  if (ground.zero_height) {
    s.position.z = ground.zero_z;
    s.pitch = 0.0;
    return true;
  }
  const auto hr = ground_height(grid, s.position.x, s.position.y, search_from_z, 60.0);
  if (!hr) return false;
  s.position.z = *hr;
  const glm::dvec2 f = glm::dvec2(s.position) + lim.wheelbase * glm::dvec2(std::cos(s.yaw), std::sin(s.yaw));
  const auto hf = ground_height(grid, f.x, f.y, *hr + ground.step_height);
  s.pitch = hf ? std::atan2(*hf - *hr, lim.wheelbase) : 0.0;
  return true;
}

glm::dmat4 vehicle_to_world(const VehicleState& s) {
  const double cy = std::cos(s.yaw), sy = std::sin(s.yaw), cp = std::cos(s.pitch), sp = std::sin(s.pitch);
  const glm::dvec3 forward{cy * cp, sy * cp, sp};
  const glm::dvec3 left{-sy, cy, 0.0};
  return flu_frame(forward, left, glm::cross(forward, left), s.position);
}

glm::dmat4 dash_camera_c2w(const VehicleState& s, const scene::Camera& cam) {
  return scene::flu_to_opencv(vehicle_to_world(s) * cam.camera_to_ego);
}

glm::dmat4 look_at_c2w(const glm::dvec3& eye, const glm::dvec3& target) {
  glm::dvec3 f = target - eye;
  const double len = glm::length(f);
  f = len > 1e-9 ? f / len : glm::dvec3(1.0, 0.0, 0.0);
  glm::dvec3 left = glm::cross(glm::dvec3(0.0, 0.0, 1.0), f);
  const double ll = glm::length(left);
  left = ll > 1e-9 ? left / ll : glm::dvec3(0.0, 1.0, 0.0);
  return scene::flu_to_opencv(flu_frame(f, left, glm::cross(f, left), eye));
}

glm::dmat4 chase_camera_c2w(const VehicleState& s, double distance, double height) {
  const glm::dvec3 h{std::cos(s.yaw), std::sin(s.yaw), 0.0};
  const glm::dvec3 eye = s.position - distance * h + glm::dvec3(0.0, 0.0, height);
  return look_at_c2w(eye, s.position + 4.0 * h + glm::dvec3(0.0, 0.0, 1.5));
}

glm::dvec3 fly_forward(const FlyCamera& f) {
  return {std::cos(f.yaw) * std::cos(f.pitch), std::sin(f.yaw) * std::cos(f.pitch), std::sin(f.pitch)};
}
glm::dvec3 fly_left(const FlyCamera& f) { return {-std::sin(f.yaw), std::cos(f.yaw), 0.0}; }

glm::dmat4 fly_camera_c2w(const FlyCamera& f) {
  const glm::dvec3 fw = fly_forward(f), left = fly_left(f);
  return scene::flu_to_opencv(flu_frame(fw, left, glm::cross(fw, left), f.position));
}

VehicleState vehicle_from_ego(const glm::dmat4& ego_to_world) {
  VehicleState s;
  s.position = glm::dvec3(ego_to_world[3]);
  const glm::dvec3 f(ego_to_world[0]);
  s.yaw = std::atan2(f.y, f.x);
  s.pitch = std::asin(std::clamp(f.z, -1.0, 1.0));
  return s;
}

std::vector<glm::dvec2> ego_path(const scene::Scene& s, double min_spacing) {
  std::vector<glm::dvec2> out;
  for (const scene::EgoPose& e : s.ego) {
    if (!e.valid) continue;
    const glm::dvec2 p(e.ego_to_world[3]);
    if (out.empty() || glm::length(p - out.back()) >= min_spacing) out.push_back(p);
  }
  return out;
}

VehicleInput autopilot_input(Autopilot& ap, const VehicleState& s, const VehicleLimits& lim) {
  VehicleInput in;
  if (ap.path.size() < 2 || ap.finished) {
    in.brake = 1.0;
    ap.finished = true;
    return in;
  }
  const glm::dvec2 p(s.position);
  // Nearest point, forwards only, within a window.
  size_t best = ap.progress;
  double best_d = glm::length(ap.path[best] - p);
  for (size_t i = ap.progress; i < std::min(ap.path.size(), ap.progress + 200); ++i) {
    const double d = glm::length(ap.path[i] - p);
    if (d < best_d) {
      best_d = d;
      best = i;
    }
  }
  ap.progress = best;
  // Look-ahead point along the path (short, so corners are not cut).
  const double ld = ap.lookahead + 0.25 * std::fabs(s.speed);
  size_t k = best;
  double acc = 0.0;
  while (k + 1 < ap.path.size() && acc < ld) {
    acc += glm::length(ap.path[k + 1] - ap.path[k]);
    ++k;
  }
  const glm::dvec2 d = ap.path[k] - p;
  const double alpha = scene::wrap_angle(std::atan2(d.y, d.x) - s.yaw);
  const double dist = std::max(1.0, glm::length(d));
  const double steer = std::atan(2.0 * lim.wheelbase * std::sin(alpha) / dist);
  in.steer = std::clamp(steer / lim.max_steer, -1.0, 1.0);
  // Speed: for each path point in the next 40 m, the curve speed there
  // (v^2 kappa <= 2 m/s^2, kappa from the heading change over 4 segments) plus
  // what braking at 2 m/s^2 gains on the way; and a stop at the end.
  double v_target = ap.target_speed, remaining = 0.0;
  const size_t n = ap.path.size();
  size_t j = best;
  auto heading = [&](size_t i) { const glm::dvec2 v = ap.path[i + 1] - ap.path[i]; return std::atan2(v.y, v.x); };
  for (; j + 1 < n && remaining < 40.0; ++j) {
    if (j + 5 < n) {
      double len = 0.0;
      for (size_t q = j; q < j + 5; ++q) len += glm::length(ap.path[q + 1] - ap.path[q]);
      const double kappa = std::fabs(scene::wrap_angle(heading(j + 4) - heading(j))) / std::max(len, 0.5);
      if (kappa > 1e-4) v_target = std::min(v_target, std::sqrt(2.0 / kappa + 2.0 * 2.0 * remaining));
    }
    remaining += glm::length(ap.path[j + 1] - ap.path[j]);
  }
  const bool near_end = j + 1 >= n;
  if (near_end) v_target = std::min(v_target, std::sqrt(std::max(0.0, 2.0 * 2.0 * (remaining - 2.0))));
  if (best + 1 >= ap.path.size() || (near_end && remaining < 2.5)) {
    ap.finished = true;
    v_target = 0.0;
  }
  const double err = v_target - s.speed;
  if (err > 0.0) in.throttle = std::clamp(err * 0.5, 0.0, 1.0);
  else in.brake = std::clamp(-err * 0.5, 0.0, 1.0);
  if (v_target == 0.0) in.brake = std::max(in.brake, std::fabs(s.speed) < 0.2 ? 0.3 : 0.6);
  return in;
}

}  // namespace icube::viewer

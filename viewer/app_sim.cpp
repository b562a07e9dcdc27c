// icube-view: simulation step, camera poses, the cars shown, adaptive resolution; see app.h.
#include "app.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace icube::viewer {

void App::simulate(double dt) {
  if (control == Control::Drive) {
    last_input = autopilot_on ? autopilot_input(autopilot, car, limits) : drive_input();
    step_vehicle(car, last_input, dt, limits, have_world ? &grid : nullptr, ground);
  } else if (control == Control::Fly) {
    fly_update(dt);
  } else if (!replay.empty()) {
    replay_t += dt;
    const Pass& p = replay[static_cast<size_t>(replay_pass)];
    if (replay_t * 10.0 >= static_cast<double>(p.size())) replay_t = 0.0;
    // The cars as `icube buffers` shows them for this frame: time index = frame (load_trajectory's rule).
    if (timeline_frames() > 0)
      time_index = std::min(static_cast<int>(replay_t * 10.0), timeline_frames() - 1);
  }
  recorder.update(sim_time, recorded_pose());
  if (timeline_frames() > 0 && play_time) {
    time_accum += dt * 10.0;
    while (time_accum >= 1.0) {
      time_accum -= 1.0;
      time_index = (time_index + 1) % timeline_frames();
    }
  }
}

int App::timeline_frames() const {
  if (scene && !scene->timestamps.empty()) return static_cast<int>(scene->timestamps.size());
  return gauss ? static_cast<int>(gauss->frames()) : 0;
}

// The moving level of detail while the view changes (driving, flying, replay, the time playing or its
// slider dragged) and for kStillAfter seconds after; then the still one, drawn once.
GaussianDetail App::gaussian_detail() const {
  const bool busy = moving() || play_time || control == Control::Replay || sim_time - view_changed_at < kStillAfter;
  return busy ? GaussianDetail::Moving : GaussianDetail::Still;
}

const gpu::Buffer* App::view_rgba() const {
  if (gaussian_mode()) return gauss->width() ? &gauss->rgba() : nullptr;
  return have_world ? &renderer.rgba() : nullptr;
}
uint32_t App::view_width() const { return gaussian_mode() ? gauss->width() : renderer.width(); }
uint32_t App::view_height() const { return gaussian_mode() ? gauss->height() : renderer.height(); }

glm::dmat4 App::recorded_pose() const {
  if (control == Control::Fly) return fly_camera_c2w(fly);
  if (control == Control::Replay && !replay.empty()) return replay_pose();
  return dash_camera_c2w(car, target_cam);
}

glm::dmat4 App::replay_pose() const {
  const Pass& p = replay[static_cast<size_t>(replay_pass)];
  return p[std::min(p.size() - 1, static_cast<size_t>(replay_t * 10.0))];
}

glm::dmat4 App::view_pose() const {
  if (control == Control::Drive && chase) return chase_camera_c2w(car);
  return recorded_pose();
}

render::Camera App::view_camera(uint32_t w, uint32_t h) const {
  render::Camera cam;
  // The target camera's vertical field of view (35 deg for the Waymo front preset) unless overridden.
  double vfov = opt.vfov * kPi / 180.0;
  if (target_cam.fy > 0.0 && target_cam.height > 0 && opt.vfov <= 0.0)
    vfov = 2.0 * std::atan(0.5 * target_cam.height / target_cam.fy);
  cam.K.fy = cam.K.fx = 0.5 * h / std::tan(0.5 * vfov);
  cam.K.cx = 0.5 * w;
  cam.K.cy = 0.5 * h;
  cam.K.width = w;
  cam.K.height = h;
  cam.c2w = view_pose();
  return cam;
}

// The scene's dynamic cars at the time index, plus our own car where the view
// shows it (chase and fly), as OverlayWorld cells (re-uploaded when they change).
void App::update_cars() {
  if (!residency || gaussian_mode()) return;  // the Gaussian view places its own cars; the voxels catch up on return
  bool changed = false;
  if (scene && !scene->timestamps.empty() && time_index != shown_time_index) {
    scene_cells = render::dynamic_car_cells(*scene, time_index, car_mesh, grid.origin(), grid.voxel_size(), nullptr,
                                            &car_cache);
    shown_time_index = time_index;
    changed = true;
  }
  const bool show_own = own_car_visible();
  const glm::dvec4 own_pose(car.position, car.yaw + car.pitch);
  if (show_own != own_shown || (show_own && own_pose != own_pose_shown)) {
    own_cells.clear();
    if (show_own) {
      if (own_box.sub_voxels.empty()) own_box = world::voxelize_mesh_in_box(car_mesh, kOwnLength, kOwnWidth, kOwnHeight);
      world::VoteOptions vo;
      vo.cell = grid.voxel_size();
      vo.grid_origin = grid.origin();
      for (const world::VehicleVoxel& v : world::vote_into_cells(own_box, own_car_box(), kOwnInstance, vo))
        own_cells.push_back({v.ijk, static_cast<uint16_t>(kOwnInstance)});
    }
    own_shown = show_own;
    own_pose_shown = own_pose;
    changed = true;
  }
  if (!changed) return;
  presenter.wait();  // the table is rewritten: no frame may still read it
  apply_cars();
}

bool App::own_car_visible() const {
  return have_world && (control == Control::Fly || (control == Control::Drive && chase));
}

scene::BoxState App::own_car_box() const {
  scene::BoxState box;
  const glm::dvec3 fwd{std::cos(car.yaw) * std::cos(car.pitch), std::sin(car.yaw) * std::cos(car.pitch), std::sin(car.pitch)};
  box.center = car.position + 0.5 * limits.wheelbase * fwd + glm::dvec3(0.0, 0.0, 0.5 * kOwnHeight);
  box.length = kOwnLength;
  box.width = kOwnWidth;
  box.height = kOwnHeight;
  box.heading = car.yaw;
  box.pitch = -car.pitch;  // Ry(pitch) turns +x down for positive angles
  box.valid = true;
  return box;
}

void App::apply_cars() {
  std::vector<render::CarCell> all = scene_cells;
  all.insert(all.end(), own_cells.begin(), own_cells.end());
  gpu_world().set_overlay(all);
}

// Chunks near the camera on the GPU (residency.h): a background job computes the change when the camera
// has moved far enough; the frame loop applies it one bounded slice per frame (the slice is the stall).
void App::update_residency() {
  if (!residency || residency->radius() <= 0.0 || gaussian_mode()) return;
  residency->update(glm::dvec2(view_pose()[3]));
  if (!residency->ready()) return;
  presenter.wait();  // the frame in flight may still read the table or the records being replaced
  const size_t swaps = residency->stats().swaps;
  residency->swap();  // keeps the car overlay
  const ResidencyStats& st = residency->stats();
  if (st.swaps != swaps)
    std::printf("icube-view: resident chunks changed: %zu bricks (+%zu, -%zu) in %zu slice(s), slowest %.1f ms; "
                "computed in %.1f ms (background)\n",
                st.resident_bricks, st.last_added, st.last_removed, st.last_steps, st.last_max_step_ms, st.last_build_ms);
}

void App::adapt_resolution() {
  const bool busy = moving() || (gaussian_mode() && gaussian_detail() == GaussianDetail::Moving);
  if (!adaptive || !busy) {
    eff_scale = scale;
    return;
  }
  const double ratio = opt.target_ms / std::max(1.0, avg_ms);
  eff_scale = std::clamp(eff_scale * std::clamp(std::sqrt(ratio), 0.85, 1.08), std::min(kMinAdaptiveScale, scale), scale);
}

}  // namespace icube::viewer

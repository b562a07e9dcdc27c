// icube-view: recording, save / load, screenshots and their checks; see app.h.
#include "app.h"

#include "render/buffers/guidance_frame.h"
#include "scene/png_write.h"
#include "world/semantics.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>

namespace icube::viewer {

void App::toggle_continuous() {
  if (recorder.continuous()) {
    recorder.stop_continuous();
    status = "continuous recording stopped (" + std::to_string(recorder.current().size()) + " poses)";
  } else {
    recorder.start_continuous(sim_time);
    status = "recording at 10 Hz";
  }
}

void App::keyframe() {
  recorder.add_keyframe(recorded_pose());
  status = "keyframe " + std::to_string(recorder.current().size());
}

void App::end_pass() {
  status = recorder.end_pass() ? "pass " + std::to_string(recorder.passes().size()) + " closed"
                               : "a pass needs at least 2 poses";
}

void App::save(const std::string& path_in) {
  const std::string path = path_in.empty() ? std::string(out_path) : path_in;
  try {
    std::vector<Pass> all = recorder.passes();
    if (all.empty() && recorder.current().size() >= 2) all.push_back(recorder.current());
    std::vector<Pass> interp;
    for (const Pass& p : all) interp.push_back(interpolate_pass(p, interp_frames));
    if (std::filesystem::path(path).has_parent_path())
      std::filesystem::create_directories(std::filesystem::path(path).parent_path());
    save_passes_npy(path, interp);
    for (size_t i = 0; i < interp.size(); ++i) save_pass_json(pass_json_path(path, i), interp[i], target_intrinsics());
    status = "saved " + std::to_string(interp.size()) + " pass(es) x " + std::to_string(interp_frames) + " to " + path;
    std::printf("icube-view: %s\n", status.c_str());
  } catch (const std::exception& e) {
    status = std::string("save failed: ") + e.what();
    std::fprintf(stderr, "icube-view: %s\n", status.c_str());
    ++failures;
  }
}

render::PinholeIntrinsics App::target_intrinsics() const {
  return {target_cam.fx, target_cam.fy, target_cam.cx, target_cam.cy, target_cam.width, target_cam.height};
}

void App::load_recording(const std::string& path) {
  try {
    replay = load_passes(path);
    replay_pass = 0;
    replay_t = 0.0;
    control = Control::Replay;
    status = "loaded " + std::to_string(replay.size()) + " pass(es) from " + path;
  } catch (const std::exception& e) {
    status = std::string("load failed: ") + e.what();
    ++failures;
  }
}

void App::request_screenshot(const std::string& path) {
  screenshot_pending = true;
  screenshot_target = path.empty() ? std::string(shot_path) : path;
}

void App::take_screenshot() {
  presenter.wait();
  const std::vector<uint8_t> px = gaussian_mode() ? gauss->download_rgba() : renderer.download_rgba();
  if (px.empty()) return;
  try {
    scene::write_png(screenshot_target, px.data(), static_cast<int>(view_width()), static_cast<int>(view_height()), 4);
    status = "screenshot " + screenshot_target;
    std::printf("icube-view: wrote %s (%ux%u, %s)\n", screenshot_target.c_str(), view_width(), view_height(),
                gaussian_mode() ? "gaussians" : kRenderModeNames[static_cast<int>(shade.mode)]);
    if (!gaussian_mode()) compare_with_headless(px);
  } catch (const std::exception& e) {
    status = std::string("screenshot failed: ") + e.what();
    ++failures;
  }
}

// The class histogram of a screenshot against the headless guidance buffer
// (render::RaycasterGpu::cast_camera + frame_from_hits) for the same pose.
// Semantic mode: pixels are palette entries, so the histograms must agree to
// L1 <= 0.02 (2 % of the pixels). Shaded mode: each pixel's class is the
// palette entry nearest to its colour divided by the colour's brightness
// relative to that entry (lighting scales a class colour; fog mixes in the
// sky), a coarser check: L1 <= kShadedL1.
void App::compare_with_headless(const std::vector<uint8_t>& px) {
  const bool semantic = shade.mode == RenderMode::Semantic;
  if (!semantic && shade.mode != RenderMode::Shaded) return;
  const std::array<double, 11> shot = semantic ? semantic_histogram(px) : shaded_histogram(px);
  std::array<double, 11> ref{};
  render::RaycasterGpu rc(ctx);
  render::RaycastOptions o;
  o.t_max = shade.max_distance;
  const render::GuidanceFrame f =
      render::frame_from_hits(rc.cast_camera(gpu_world().world(), last_cam, o), last_cam.K, o.pixels);
  for (uint8_t c : f.classes) ref[world::palette_index(c)] += 1.0;
  const double n = static_cast<double>(f.classes.size());
  const double l1 = histogram_l1(shot, ref, n);
  const double limit = semantic ? 0.02 : kShadedL1;
  std::printf("icube-view: %s screenshot class histogram vs headless buffer: L1 %.4f (limit %.2f; %.0f%% road/ground, %.0f%% sky)\n",
              kRenderModeNames[static_cast<int>(shade.mode)], l1, limit, 100.0 * ref[7] / n, 100.0 * ref[8] / n);
  if (l1 > limit || ref[8] > 0.98 * n) {
    std::fprintf(stderr, "icube-view: error: the screenshot does not match the headless buffer (or shows no world)\n");
    ++failures;
  }
}

// The previewed frame F of replay pass P, rendered exactly as `icube buffers`
// renders that pose of the saved file: the target camera's intrinsics, integer
// pixel convention, no distance limit, the scene's moving cars at time index
// min(F, states - 1) (render::load_trajectory's rule for files without
// time_indices), semantic mode. PNG RGB8.
void App::frame_shot(const std::string& path, size_t pass, size_t frame) {
  try {
    if (!have_world) throw std::runtime_error("no world");
    if (pass >= replay.size() || frame >= replay[pass].size())
      throw std::invalid_argument("frame-shot: no frame " + std::to_string(frame) + " of pass " + std::to_string(pass) +
                                  " (load a trajectory first)");
    presenter.wait();
    std::vector<render::CarCell> cars;
    if (scene && !scene->timestamps.empty()) {
      const int ti = static_cast<int>(std::min(frame, scene->timestamps.size() - 1));
      cars = render::dynamic_car_cells(*scene, ti, car_mesh, grid.origin(), grid.voxel_size(), nullptr, &car_cache);
    }
    gpu_world().set_overlay(cars);
    render::Camera cam;
    cam.K = target_intrinsics();
    cam.c2w = replay[pass][frame];
    ShadeSettings s;
    s.mode = RenderMode::Semantic;
    s.max_distance = std::numeric_limits<double>::infinity();
    ctx.submit_and_wait([&](gpu::CommandList& cmd) { renderer.record(cmd, gpu_world().world(), cam, s); });
    const std::vector<uint8_t> rgba = renderer.download_rgba();
    std::vector<uint8_t> rgb(rgba.size() / 4 * 3);
    for (size_t i = 0; i < rgba.size() / 4; ++i)
      for (int c = 0; c < 3; ++c) rgb[3 * i + static_cast<size_t>(c)] = rgba[4 * i + static_cast<size_t>(c)];
    scene::write_png(path, rgb.data(), static_cast<int>(cam.K.width), static_cast<int>(cam.K.height), 3);
    status = "frame " + std::to_string(frame) + " of pass " + std::to_string(pass) + " -> " + path;
    std::printf("icube-view: wrote %s (pass %zu frame %zu, %ux%u, semantic, target camera)\n", path.c_str(), pass, frame,
                cam.K.width, cam.K.height);
    apply_cars();  // the cars back as they were
  } catch (const std::exception& e) {
    status = std::string("frame-shot failed: ") + e.what();
    std::fprintf(stderr, "icube-view: error: %s\n", status.c_str());
    ++failures;
  }
}

// The previewed frame F of replay pass P drawn from the Gaussians as `icube splat render
// gaussians/scene.json --trajectory FILE --camera <target> --sky gaussians/sky.png` draws that pose
// of the saved file: the target camera's intrinsics, the whole static set (no level of detail),
// the moving objects at splat frame min(F, frames - 1), the sky. PNG RGB8.
void App::gaussian_frame_shot(const std::string& path, size_t pass, size_t frame) {
  try {
    if (!gauss) throw std::runtime_error("no Gaussians (open a package)");
    if (pass >= replay.size() || frame >= replay[pass].size())
      throw std::invalid_argument("gaussian-shot: no frame " + std::to_string(frame) + " of pass " +
                                  std::to_string(pass) + " (load a trajectory first)");
    presenter.wait();
    render::Camera cam;
    cam.K = target_intrinsics();
    cam.c2w = replay[pass][frame];
    gauss->draw(cam, frame, GaussianDetail::Whole);
    const std::vector<uint8_t> rgba = gauss->download_rgba();
    std::vector<uint8_t> rgb(rgba.size() / 4 * 3);
    for (size_t i = 0; i < rgba.size() / 4; ++i)
      for (int c = 0; c < 3; ++c) rgb[3 * i + static_cast<size_t>(c)] = rgba[4 * i + static_cast<size_t>(c)];
    scene::write_png(path, rgb.data(), static_cast<int>(cam.K.width), static_cast<int>(cam.K.height), 3);
    status = "Gaussian frame " + std::to_string(frame) + " of pass " + std::to_string(pass) + " -> " + path;
    std::printf("icube-view: wrote %s (pass %zu frame %zu, %ux%u, Gaussians, whole set, target camera)\n", path.c_str(),
                pass, frame, cam.K.width, cam.K.height);
  } catch (const std::exception& e) {
    status = std::string("gaussian-shot failed: ") + e.what();
    std::fprintf(stderr, "icube-view: error: %s\n", status.c_str());
    ++failures;
  }
}

void App::finish_autopilot() {
  if (recorder.continuous()) {
    recorder.stop_continuous();
    end_pass();
    save(opt.record_out);
  }
  presenter.wait();
  if (view_rgba()) {
    screenshot_target = opt.screenshot_out;
    take_screenshot();
  }
  quit = true;
}

}  // namespace icube::viewer

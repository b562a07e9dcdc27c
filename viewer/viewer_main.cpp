// icube-view: the interactive viewer. Drive a car (or fly) through a semantic
// voxel world rendered by the compute ray caster, record camera trajectories
// for Stage 2, replay them. GLFW + Vulkan swapchain + Dear ImGui (presenter.h);
// the view is shaders/raycast.comp + shaders/view_shade.comp (view_renderer.h);
// the car, recorder and scripts are CPU code in icube_viewer_core.
//
//   icube-view world.icw [--scene scene.json]   a world (and its scene: ego track, cars, camera)
//   icube-view --scene scene.json               builds the scene's world with the procedural prior
//   icube-view OUTPUT_DIR                        a folder holding world.icw (+ scene.json)
//   --script FILE | --autopilot, --record-out, --screenshot-out, --stats, --frames N (smoke tests)
#include "presenter.h"
#include "recorder.h"
#include "script.h"
#include "vehicle.h"
#include "view_renderer.h"

#include "gpu/context.h"
#include "render/buffers/frame_scene.h"
#include "render/buffers/guidance_frame.h"
#include "render/buffers/overlay_world.h"
#include "scene/frames.h"
#include "scene/png_write.h"
#include "scene/scene_load.h"
#include "world/car_mesh.h"
#include "world/mesh_voxelize.h"
#include "world/procedural/procedural_prior.h"
#include "world/semantics.h"
#include "world/world_build.h"
#include "world/world_file.h"

#include <CLI/CLI.hpp>
#include <imgui.h>
#include <imgui_impl_glfw.h>
#include <imgui_impl_vulkan.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <deque>
#include <filesystem>
#include <map>
#include <optional>
#include <set>
#include <string>

namespace icube::viewer {
namespace {

constexpr double kScriptDt = 1.0 / 30.0;  // simulated seconds per frame in scripted / autopilot runs
constexpr double kPi = 3.14159265358979323846;

struct Options {
  std::string input, scene_path, script, record_out = "recording.npy", screenshot_out = "screenshot.png", load;
  int frames = 0, width = 1280, height = 720, interp_frames = kDefaultInterpolatedFrames;
  bool autopilot = false, stats = false, vsync = true, adaptive = false, fly = false, check = false;
  double scale = 1.0, vfov = 35.0, max_seconds = 900.0, target_ms = 50.0;
  std::string mode = "shaded";
  std::string verify;
  size_t expect_passes = 0;
};

enum class Control { Drive, Fly, Replay };

struct Viewer {
  Options opt;
  gpu::Context& ctx;
  GLFWwindow* window;
  Presenter presenter;
  ViewRenderer renderer;

  // Content.
  world::VoxelGrid grid;
  bool have_world = false;
  std::optional<scene::Scene> scene;
  std::unique_ptr<render::OverlayWorld> overlay;
  world::TriangleMesh car_mesh;
  render::CarVoxelCache car_cache;
  int time_index = 0, shown_time_index = -1;
  static constexpr uint32_t kOwnInstance = 9999;  // our car: below the dynamic ids, above static ones
  std::vector<render::CarCell> scene_cells, own_cells;
  world::BoxVoxelization own_box;
  bool own_shown = false;
  glm::dvec4 own_pose_shown{0.0};
  bool play_time = false;
  double time_accum = 0.0;
  scene::Camera target_cam;
  std::string world_name = "(none)";

  // Control.
  Control control = Control::Drive;
  bool chase = true;
  VehicleState car;
  VehicleLimits limits;
  GroundOptions ground;
  FlyCamera fly;
  Autopilot autopilot;
  bool autopilot_on = false;
  VehicleInput last_input;
  std::set<std::string> script_keys;
  std::map<int, bool> prev_keys;
  double mouse_x = 0.0, mouse_y = 0.0;
  bool mouse_look = false;

  // View.
  ShadeSettings shade;
  double scale = 1.0, eff_scale = 1.0;
  bool adaptive = false;
  bool show_path = true;

  // Recording / replay.
  Recorder recorder;
  int interp_frames = kDefaultInterpolatedFrames;
  std::vector<Pass> replay;
  int replay_pass = 0;
  double replay_t = 0.0;
  char out_path[512] = {};
  char load_path[512] = {};
  char shot_path[512] = {};
  std::string status;
  bool screenshot_pending = false;
  std::string screenshot_target;

  // Session.
  std::optional<ScriptPlayer> script;
  bool scripted = false;
  double sim_time = 0.0;
  bool quit = false;
  int failures = 0;
  FrameStats stats;
  std::deque<float> frame_graph;
  double last_frame_ms = 0.0, avg_ms = 16.0;
  render::Camera last_cam;

  Viewer(const Options& o, gpu::Context& c, GLFWwindow* w)
      : opt(o), ctx(c), window(w), presenter(c, w, o.vsync), renderer(c) {
    scale = eff_scale = o.scale;
    adaptive = o.adaptive;
    interp_frames = o.interp_frames;
    for (size_t m = 0; m < std::size(kRenderModeNames); ++m)
      if (o.mode == kRenderModeNames[m]) shade.mode = static_cast<RenderMode>(m);
    std::snprintf(out_path, sizeof out_path, "%s", o.record_out.c_str());
    std::snprintf(shot_path, sizeof shot_path, "%s", o.screenshot_out.c_str());
    std::snprintf(load_path, sizeof load_path, "%s", o.load.empty() ? o.record_out.c_str() : o.load.c_str());
    target_cam = scene::waymo_front_camera();
  }

  // ---- loading ----------------------------------------------------------------
  void load() {
    std::string world_path = opt.input, scene_path = opt.scene_path;
    if (!world_path.empty() && std::filesystem::is_directory(world_path)) {
      const std::filesystem::path dir(world_path);
      world_path = (dir / "world.icw").string();
      if (scene_path.empty() && std::filesystem::exists(dir / "scene.json")) scene_path = (dir / "scene.json").string();
    }
    if (!scene_path.empty()) {
      scene = scene::load_scene(scene_path);
      if (!scene->cameras.empty() && scene->cameras[0].fy > 0.0) target_cam = scene->cameras[0];
    }
    if (!world_path.empty()) {
      grid = world::load_world(world_path);
      world_name = world_path;
      have_world = true;
    } else if (scene) {
      std::printf("icube-view: building the scene's world with the procedural prior...\n");
      std::fflush(stdout);
      world::ProceduralPrior prior(*scene);
      grid = world::build_world(*scene, prior).world;
      world_name = scene_path + " (procedural prior)";
      have_world = true;
    }
    if (have_world) {
      car_mesh = world::builtin_car_mesh();
      const world::VoxelGrid static_world =
          scene ? render::make_static_world(grid, *scene, 0, car_mesh) : grid;
      overlay = std::make_unique<render::OverlayWorld>(ctx, static_world);
      if (scene) grid = static_world;  // ground following sees what is drawn
    }
    if (scene) autopilot.path = ego_path(*scene);
    teleport(scene && !scene->ego.empty() ? "ego" : "origin");
    if (!opt.load.empty()) load_recording(opt.load);
  }

  void teleport(const std::string& where) {
    if (where == "ego" && scene) {
      for (const scene::EgoPose& e : scene->ego)
        if (e.valid) {
          car = vehicle_from_ego(e.ego_to_world);
          break;
        }
      autopilot.progress = 0;
      autopilot.finished = false;
    } else if (have_world) {
      const world::IjkBounds b = grid.bounds();
      const glm::dvec3 c = 0.5 * (grid.ijk_to_world(b.min) + grid.ijk_to_world(b.max));
      car = VehicleState{};
      car.position = c;
    }
    car.speed = 0.0;
    ground.zero_z = car.position.z;
    if (have_world) {
      const double top = grid.origin().z + (grid.bounds().max.z + 2) * grid.voxel_size();
      if (!settle_vehicle(car, limits, grid, ground, std::max(top, car.position.z + 2.0)) && !scene)
        car.position.z = 0.0;
      ground.zero_z = car.position.z;
    }
    fly.position = car.position + glm::dvec3(0, 0, 6.0) - 8.0 * glm::dvec3(std::cos(car.yaw), std::sin(car.yaw), 0);
    fly.yaw = car.yaw;
    fly.pitch = -0.25;
  }

  // ---- input --------------------------------------------------------------------
  static int glfw_key(const std::string& k) {
    static const std::map<std::string, int> m = {
        {"W", GLFW_KEY_W}, {"A", GLFW_KEY_A}, {"S", GLFW_KEY_S}, {"D", GLFW_KEY_D}, {"UP", GLFW_KEY_UP},
        {"DOWN", GLFW_KEY_DOWN}, {"LEFT", GLFW_KEY_LEFT}, {"RIGHT", GLFW_KEY_RIGHT}, {"SPACE", GLFW_KEY_SPACE},
        {"SHIFT", GLFW_KEY_LEFT_SHIFT}, {"Q", GLFW_KEY_Q}, {"E", GLFW_KEY_E}};
    return m.at(k);
  }
  bool held(const std::string& k) const {
    if (script_keys.count(k)) return true;
    if (ImGui::GetIO().WantCaptureKeyboard) return false;
    return glfwGetKey(window, glfw_key(k)) == GLFW_PRESS;
  }
  bool pressed(int key) {  // edge-triggered keyboard shortcut
    const bool now = glfwGetKey(window, key) == GLFW_PRESS && !ImGui::GetIO().WantCaptureKeyboard;
    const bool was = prev_keys[key];
    prev_keys[key] = now;
    return now && !was;
  }

  void shortcuts() {
    if (pressed(GLFW_KEY_ESCAPE)) quit = true;
    if (pressed(GLFW_KEY_TAB)) control = control == Control::Drive ? Control::Fly : Control::Drive;
    if (pressed(GLFW_KEY_C)) chase = !chase;
    if (pressed(GLFW_KEY_R)) toggle_continuous();
    if (pressed(GLFW_KEY_K)) keyframe();
    if (pressed(GLFW_KEY_P)) end_pass();
    if (pressed(GLFW_KEY_F12)) request_screenshot("");
    if (pressed(GLFW_KEY_Z)) ground.zero_height = !ground.zero_height;
    for (int m = 0; m < 5; ++m)
      if (pressed(GLFW_KEY_1 + m)) shade.mode = static_cast<RenderMode>(m);
  }

  VehicleInput drive_input() {
    VehicleInput in;
    in.throttle = (held("W") || held("UP")) ? 1.0 : 0.0;
    in.brake = (held("S") || held("DOWN")) ? 1.0 : 0.0;
    if (held("SPACE")) in.brake = 1.0;
    in.steer = ((held("A") || held("LEFT")) ? 1.0 : 0.0) - ((held("D") || held("RIGHT")) ? 1.0 : 0.0);
    GLFWgamepadstate pad;
    if (glfwJoystickIsGamepad(GLFW_JOYSTICK_1) && glfwGetGamepadState(GLFW_JOYSTICK_1, &pad)) {
      const double steer = -pad.axes[GLFW_GAMEPAD_AXIS_LEFT_X];
      const double rt = 0.5 * (double(pad.axes[GLFW_GAMEPAD_AXIS_RIGHT_TRIGGER]) + 1.0);
      const double lt = 0.5 * (double(pad.axes[GLFW_GAMEPAD_AXIS_LEFT_TRIGGER]) + 1.0);
      if (std::fabs(steer) > 0.1) in.steer = steer;
      in.throttle = std::max(in.throttle, rt > 0.05 ? rt : 0.0);
      in.brake = std::max(in.brake, lt > 0.05 ? lt : 0.0);
    }
    return in;
  }

  void fly_update(double dt) {
    const double speed = (held("SHIFT") ? 40.0 : 10.0) * dt;
    glm::dvec3 move(0.0);
    if (held("W") || held("UP")) move += fly_forward(fly);
    if (held("S") || held("DOWN")) move -= fly_forward(fly);
    if (held("A") || held("LEFT")) move += fly_left(fly);
    if (held("D") || held("RIGHT")) move -= fly_left(fly);
    if (held("E")) move.z += 1.0;
    if (held("Q")) move.z -= 1.0;
    GLFWgamepadstate pad;
    if (glfwJoystickIsGamepad(GLFW_JOYSTICK_1) && glfwGetGamepadState(GLFW_JOYSTICK_1, &pad)) {
      auto dz = [](float v) { return std::fabs(v) > 0.12f ? double(v) : 0.0; };
      move += -dz(pad.axes[GLFW_GAMEPAD_AXIS_LEFT_Y]) * fly_forward(fly) - dz(pad.axes[GLFW_GAMEPAD_AXIS_LEFT_X]) * fly_left(fly);
      fly.yaw -= 2.0 * dt * dz(pad.axes[GLFW_GAMEPAD_AXIS_RIGHT_X]);
      fly.pitch -= 1.5 * dt * dz(pad.axes[GLFW_GAMEPAD_AXIS_RIGHT_Y]);
    }
    fly.position += speed * move;
    // Mouse look: hold the right button.
    double mx = 0.0, my = 0.0;
    glfwGetCursorPos(window, &mx, &my);
    const bool down = glfwGetMouseButton(window, GLFW_MOUSE_BUTTON_RIGHT) == GLFW_PRESS && !ImGui::GetIO().WantCaptureMouse;
    if (down && mouse_look) {
      fly.yaw -= 0.004 * (mx - mouse_x);
      fly.pitch -= 0.004 * (my - mouse_y);
    }
    mouse_look = down;
    mouse_x = mx;
    mouse_y = my;
    fly.pitch = std::clamp(fly.pitch, -1.5, 1.5);
  }

  bool moving() const {
    if (control == Control::Drive) return std::fabs(car.speed) > 0.3;
    if (control == Control::Replay) return true;
    return mouse_look || held("W") || held("A") || held("S") || held("D") || held("Q") || held("E");
  }

  // ---- simulation -----------------------------------------------------------------
  void simulate(double dt) {
    if (control == Control::Drive) {
      last_input = autopilot_on ? autopilot_input(autopilot, car, limits) : drive_input();
      step_vehicle(car, last_input, dt, limits, have_world ? &grid : nullptr, ground);
    } else if (control == Control::Fly) {
      fly_update(dt);
    } else if (!replay.empty()) {
      replay_t += dt;
      const Pass& p = replay[static_cast<size_t>(replay_pass)];
      if (replay_t * 10.0 >= static_cast<double>(p.size())) replay_t = 0.0;
    }
    recorder.update(sim_time, recorded_pose());
    if (scene && !scene->timestamps.empty()) {
      if (play_time) {
        time_accum += dt * 10.0;
        while (time_accum >= 1.0) {
          time_accum -= 1.0;
          time_index = (time_index + 1) % static_cast<int>(scene->timestamps.size());
        }
      }
    }
  }

  glm::dmat4 recorded_pose() const {
    if (control == Control::Fly) return fly_camera_c2w(fly);
    if (control == Control::Replay && !replay.empty()) return replay_pose();
    return dash_camera_c2w(car, target_cam);
  }
  glm::dmat4 replay_pose() const {
    const Pass& p = replay[static_cast<size_t>(replay_pass)];
    return p[std::min(p.size() - 1, static_cast<size_t>(replay_t * 10.0))];
  }
  glm::dmat4 view_pose() const {
    if (control == Control::Drive && chase) return chase_camera_c2w(car);
    return recorded_pose();
  }

  render::Camera view_camera(uint32_t w, uint32_t h) const {
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

  // ---- recording --------------------------------------------------------------------
  void toggle_continuous() {
    if (recorder.continuous()) {
      recorder.stop_continuous();
      status = "continuous recording stopped (" + std::to_string(recorder.current().size()) + " poses)";
    } else {
      recorder.start_continuous(sim_time);
      status = "recording at 10 Hz";
    }
  }
  void keyframe() {
    recorder.add_keyframe(recorded_pose());
    status = "keyframe " + std::to_string(recorder.current().size());
  }
  void end_pass() {
    status = recorder.end_pass() ? "pass " + std::to_string(recorder.passes().size()) + " closed"
                                 : "a pass needs at least 2 poses";
  }
  void save(const std::string& path_in) {
    const std::string path = path_in.empty() ? std::string(out_path) : path_in;
    try {
      std::vector<Pass> all = recorder.passes();
      if (all.empty() && recorder.current().size() >= 2) all.push_back(recorder.current());
      std::vector<Pass> interp;
      for (const Pass& p : all) interp.push_back(interpolate_pass(p, interp_frames));
      if (std::filesystem::path(path).has_parent_path())
        std::filesystem::create_directories(std::filesystem::path(path).parent_path());
      save_passes_npy(path, interp);
      const render::PinholeIntrinsics K{target_cam.fx, target_cam.fy, target_cam.cx, target_cam.cy, target_cam.width, target_cam.height};
      for (size_t i = 0; i < interp.size(); ++i) save_pass_json(pass_json_path(path, i), interp[i], K);
      status = "saved " + std::to_string(interp.size()) + " pass(es) x " + std::to_string(interp_frames) + " to " + path;
      std::printf("icube-view: %s\n", status.c_str());
    } catch (const std::exception& e) {
      status = std::string("save failed: ") + e.what();
      std::fprintf(stderr, "icube-view: %s\n", status.c_str());
      ++failures;
    }
  }
  void load_recording(const std::string& path) {
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
  void request_screenshot(const std::string& path) {
    screenshot_pending = true;
    screenshot_target = path.empty() ? std::string(shot_path) : path;
  }
  void take_screenshot() {
    presenter.wait();
    const std::vector<uint8_t> px = renderer.download_rgba();
    if (px.empty()) return;
    try {
      scene::write_png(screenshot_target, px.data(), static_cast<int>(renderer.width()), static_cast<int>(renderer.height()), 4);
      status = "screenshot " + screenshot_target;
      std::printf("icube-view: wrote %s (%ux%u, %s)\n", screenshot_target.c_str(), renderer.width(), renderer.height(),
                  kRenderModeNames[static_cast<int>(shade.mode)]);
      if (shade.mode == RenderMode::Semantic) compare_with_headless(px);
    } catch (const std::exception& e) {
      status = std::string("screenshot failed: ") + e.what();
      ++failures;
    }
  }

  // The class histogram of a semantic screenshot against the headless guidance
  // buffer (render::RaycasterGpu::cast_camera + frame_from_hits) for the same pose.
  void compare_with_headless(const std::vector<uint8_t>& px) {
    std::array<double, 11> shot{}, ref{};  // 10 palette entries + "other"
    for (size_t i = 0; i + 3 < px.size(); i += 4) {
      size_t k = 10;
      for (size_t e = 0; e < world::kGuidancePalette.size(); ++e)
        if (px[i] == world::kGuidancePalette[e][0] && px[i + 1] == world::kGuidancePalette[e][1] &&
            px[i + 2] == world::kGuidancePalette[e][2])
          k = e;
      shot[k] += 1.0;
    }
    render::RaycasterGpu rc(ctx);
    render::RaycastOptions o;
    o.t_max = shade.max_distance;
    const render::GuidanceFrame f =
        render::frame_from_hits(rc.cast_camera(overlay->world(), last_cam, o), last_cam.K, o.pixels);
    for (uint8_t c : f.classes) ref[world::palette_index(c)] += 1.0;
    double l1 = 0.0;
    const double n = static_cast<double>(f.classes.size());
    for (size_t k = 0; k < shot.size(); ++k) l1 += std::fabs(shot[k] - ref[k]) / n;
    std::printf("icube-view: screenshot class histogram vs headless buffer: L1 %.4f (%.0f%% road/ground, %.0f%% sky)\n", l1,
                100.0 * ref[7] / n, 100.0 * ref[8] / n);
    if (l1 > 0.02 || ref[8] > 0.98 * n) {
      std::fprintf(stderr, "icube-view: error: the screenshot does not match the headless buffer (or shows no world)\n");
      ++failures;
    }
  }

  // ---- script -------------------------------------------------------------------
  void run_event(const ScriptEvent& e) {
    const std::string a = e.args.empty() ? "" : e.args[0];
    if (e.command == "down") script_keys.insert(a);
    else if (e.command == "up") script_keys.erase(a);
    else if (e.command == "mode") control = a == "fly" ? Control::Fly : Control::Drive;
    else if (e.command == "camera") chase = a == "chase";
    else if (e.command == "render") {
      for (size_t m = 0; m < std::size(kRenderModeNames); ++m)
        if (a == kRenderModeNames[m]) shade.mode = static_cast<RenderMode>(m);
    } else if (e.command == "scale") scale = eff_scale = std::stod(a);
    else if (e.command == "adaptive") adaptive = a == "on";
    else if (e.command == "zero-height") {
      ground.zero_height = a == "on";
      ground.zero_z = car.position.z;
    } else if (e.command == "autopilot") autopilot_on = a == "on" && !autopilot.path.empty();
    else if (e.command == "record") {
      if (a == "start") recorder.start_continuous(sim_time);
      else if (a == "stop") recorder.stop_continuous();
      else if (a == "key") keyframe();
      else if (a == "pass") end_pass();
      else recorder.clear();
    } else if (e.command == "save") save(a);
    else if (e.command == "screenshot") request_screenshot(a);
    else if (e.command == "teleport") teleport(a);
    else if (e.command == "quit") quit = true;
    std::printf("icube-view: t=%.2f %s %s%s\n", sim_time, e.command.c_str(), a.c_str(),
                status.empty() ? "" : ("  [" + status + "]").c_str());
  }

  // ---- UI -----------------------------------------------------------------------------
  void ui() {
    ImGui::SetNextWindowPos(ImVec2(8, 8), ImGuiCond_FirstUseEver);
    ImGui::SetNextWindowSize(ImVec2(330, 0), ImGuiCond_FirstUseEver);
    ImGui::Begin("icube-view");
    if (ImGui::CollapsingHeader("View", ImGuiTreeNodeFlags_DefaultOpen)) {
      ImGui::Text("%.1f fps  %.1f ms  (%s)", last_frame_ms > 0 ? 1000.0 / last_frame_ms : 0.0, last_frame_ms,
                  presenter.present_mode_name());
      std::vector<float> g(frame_graph.begin(), frame_graph.end());
      ImGui::PlotLines("##ft", g.data(), static_cast<int>(g.size()), 0, "frame ms", 0.0f, 100.0f, ImVec2(0, 50));
      ImGui::Text("render %ux%u of %ux%u", renderer.width(), renderer.height(), presenter.extent().width,
                  presenter.extent().height);
      int mode = static_cast<int>(shade.mode);
      if (ImGui::Combo("mode", &mode, kRenderModeNames, static_cast<int>(std::size(kRenderModeNames))))
        shade.mode = static_cast<RenderMode>(mode);
      float s = static_cast<float>(scale);
      if (ImGui::SliderFloat("res scale", &s, 0.25f, 1.0f)) scale = eff_scale = s;
      ImGui::Checkbox("adaptive while moving", &adaptive);
      float fog = static_cast<float>(shade.fog_density * 1000.0);
      if (ImGui::SliderFloat("fog /km", &fog, 0.0f, 20.0f)) shade.fog_density = double(fog) / 1000.0;
      ImGui::Checkbox("path preview", &show_path);
      ImGui::TextDisabled("Gaussians: not yet (splatting renderer)");
    }
    if (ImGui::CollapsingHeader("World and scene", ImGuiTreeNodeFlags_DefaultOpen)) {
      ImGui::TextWrapped("world: %s", world_name.c_str());
      if (have_world) {
        const world::IjkBounds b = grid.bounds();
        ImGui::Text("%llu voxels, %zu bricks (all resident)", static_cast<unsigned long long>(grid.voxel_count()),
                    grid.brick_count());
        ImGui::Text("extent %.0f x %.0f x %.0f m", (b.max.x - b.min.x + 1) * grid.voxel_size(),
                    (b.max.y - b.min.y + 1) * grid.voxel_size(), (b.max.z - b.min.z + 1) * grid.voxel_size());
      }
      if (scene) {
        ImGui::TextWrapped("scene: %s (%s)", scene->provenance.scenario_id.c_str(), scene->provenance.source_format.c_str());
        ImGui::Text("%zu tracks, %zu ego poses", scene->tracks.size(), scene->ego.size());
        if (!scene->timestamps.empty()) {
          ImGui::SliderInt("time", &time_index, 0, static_cast<int>(scene->timestamps.size()) - 1);
          ImGui::Checkbox("play cars (10 Hz)", &play_time);
        }
      }
    }
    if (ImGui::CollapsingHeader("Drive", ImGuiTreeNodeFlags_DefaultOpen)) {
      int c = static_cast<int>(control);
      ImGui::RadioButton("drive", &c, 0);
      ImGui::SameLine();
      ImGui::RadioButton("fly", &c, 1);
      ImGui::SameLine();
      ImGui::RadioButton("replay", &c, 2);
      control = static_cast<Control>(c);
      if (control == Control::Drive) {
        ImGui::Checkbox("chase camera (C)", &chase);
        const double kmh = std::fabs(car.speed) * 3.6;
        ImGui::Text("%5.1f km/h %s", kmh, car.reversing ? "R" : "D");
        ImGui::ProgressBar(static_cast<float>(kmh / (limits.max_speed * 3.6)), ImVec2(-1, 0), "");
        ImGui::Text("steer %+.1f deg  pitch %+.1f deg", car.steer * 180 / kPi, car.pitch * 180 / kPi);
        if (ImGui::Checkbox("always zero height (Z)", &ground.zero_height)) ground.zero_z = car.position.z;
        if (!autopilot.path.empty()) ImGui::Checkbox("autopilot (ego track)", &autopilot_on);
      }
      const glm::dvec3 p = glm::dvec3(view_pose()[3]);
      ImGui::Text("camera %.1f %.1f %.1f m", p.x, p.y, p.z);
      if (scene && ImGui::Button("to ego start")) teleport("ego");
      if (scene) ImGui::SameLine();
      if (ImGui::Button("to world centre")) teleport("origin");
    }
    if (ImGui::CollapsingHeader("Record", ImGuiTreeNodeFlags_DefaultOpen)) {
      if (ImGui::Button(recorder.continuous() ? "stop 10 Hz (R)" : "record 10 Hz (R)")) toggle_continuous();
      ImGui::SameLine();
      if (ImGui::Button("keyframe (K)")) keyframe();
      ImGui::SameLine();
      if (ImGui::Button("end pass (P)")) end_pass();
      ImGui::Text("current %zu poses, %zu pass(es)", recorder.current().size(), recorder.passes().size());
      ImGui::InputInt("frames", &interp_frames);
      interp_frames = std::clamp(interp_frames, 2, 10000);
      ImGui::InputText("out", out_path, sizeof out_path);
      if (ImGui::Button("save .npy + .json")) save("");
      ImGui::SameLine();
      if (ImGui::Button("clear")) recorder.clear();
      ImGui::InputText("load", load_path, sizeof load_path);
      if (ImGui::Button("load + replay")) load_recording(load_path);
      if (!replay.empty()) {
        ImGui::SameLine();
        ImGui::SliderInt("pass", &replay_pass, 0, static_cast<int>(replay.size()) - 1);
      }
      ImGui::InputText("png", shot_path, sizeof shot_path);
      if (ImGui::Button("screenshot (F12)")) request_screenshot("");
      if (!status.empty()) ImGui::TextWrapped("%s", status.c_str());
    }
    ImGui::TextDisabled("WASD/arrows drive or fly, Tab drive/fly, RMB look, Q/E down/up, 1-5 modes, Esc quit");
    ImGui::End();
    if (show_path) draw_paths();
  }

  // Recorded passes (and the current one) projected into the view.
  void draw_paths() {
    ImDrawList* dl = ImGui::GetBackgroundDrawList();
    const VkExtent2D ext = presenter.extent();
    const render::Camera cam = view_camera(ext.width, ext.height);
    const glm::dmat4 w2c = glm::inverse(cam.c2w);
    auto draw = [&](const Pass& p, ImU32 color, bool dots) {
      std::optional<ImVec2> prev;
      for (const glm::dmat4& m : p) {
        const glm::dvec3 x = glm::dvec3(w2c * glm::dvec4(glm::dvec3(m[3]) - glm::dvec3(0, 0, 1.5), 1.0));
        if (x.z < 0.5) {
          prev.reset();
          continue;
        }
        const ImVec2 q(static_cast<float>(cam.K.fx * x.x / x.z + cam.K.cx), static_cast<float>(cam.K.fy * x.y / x.z + cam.K.cy));
        if (prev) dl->AddLine(*prev, q, color, 2.0f);
        if (dots) dl->AddCircleFilled(q, 2.5f, color);
        prev = q;
      }
    };
    for (const Pass& p : recorder.passes()) draw(p, IM_COL32(255, 80, 40, 255), false);
    draw(recorder.current(), IM_COL32(255, 230, 0, 255), true);
    if (control != Control::Replay)
      for (const Pass& p : replay) draw(p, IM_COL32(60, 200, 255, 255), false);
  }

  // ---- frame ------------------------------------------------------------------------
  // The scene's dynamic cars at the time index, plus our own car where the view
  // shows it (chase and fly), as OverlayWorld cells (re-uploaded when they change).
  void update_cars() {
    if (!overlay) return;
    bool changed = false;
    if (scene && !scene->timestamps.empty() && time_index != shown_time_index) {
      scene_cells = render::dynamic_car_cells(*scene, time_index, car_mesh, grid.origin(), grid.voxel_size(), nullptr,
                                              &car_cache);
      shown_time_index = time_index;
      changed = true;
    }
    const bool show_own = control == Control::Fly || (control == Control::Drive && chase);
    const glm::dvec4 own_pose(car.position, car.yaw + car.pitch);
    if (show_own != own_shown || (show_own && own_pose != own_pose_shown)) {
      own_cells.clear();
      if (show_own) {
        if (own_box.sub_voxels.empty()) own_box = world::voxelize_mesh_in_box(car_mesh, 4.6, 2.0, 1.6);
        scene::BoxState box;
        const glm::dvec3 fwd{std::cos(car.yaw) * std::cos(car.pitch), std::sin(car.yaw) * std::cos(car.pitch), std::sin(car.pitch)};
        box.center = car.position + 0.5 * limits.wheelbase * fwd + glm::dvec3(0.0, 0.0, 0.8);
        box.length = 4.6;
        box.width = 2.0;
        box.height = 1.6;
        box.heading = car.yaw;
        box.pitch = -car.pitch;  // Ry(pitch) turns +x down for positive angles
        box.valid = true;
        world::VoteOptions vo;
        vo.cell = grid.voxel_size();
        vo.grid_origin = grid.origin();
        for (const world::VehicleVoxel& v : world::vote_into_cells(own_box, box, kOwnInstance, vo))
          own_cells.push_back({v.ijk, static_cast<uint16_t>(kOwnInstance)});
      }
      own_shown = show_own;
      own_pose_shown = own_pose;
      changed = true;
    }
    if (!changed) return;
    presenter.wait();  // the table is rewritten: no frame may still read it
    std::vector<render::CarCell> all = scene_cells;
    all.insert(all.end(), own_cells.begin(), own_cells.end());
    overlay->set_overlay(all);
  }

  void adapt_resolution() {
    if (!adaptive || !moving()) {
      eff_scale = scale;
      return;
    }
    const double ratio = opt.target_ms / std::max(1.0, avg_ms);
    eff_scale = std::clamp(eff_scale * std::clamp(std::sqrt(ratio), 0.85, 1.08), 0.3, scale);
  }

  int run() {
    using clock = std::chrono::steady_clock;
    auto last = clock::now();
    int frame = 0;
    while (!glfwWindowShouldClose(window) && !quit) {
      glfwPollEvents();
      const auto now = clock::now();
      const double wall_dt = std::chrono::duration<double>(now - last).count();
      last = now;
      if (frame > 0) {
        last_frame_ms = wall_dt * 1000.0;
        avg_ms = 0.8 * avg_ms + 0.2 * last_frame_ms;
        if (frame > 3) stats.add(last_frame_ms);
        frame_graph.push_back(static_cast<float>(last_frame_ms));
        if (frame_graph.size() > 240) frame_graph.pop_front();
      }
      const double dt = scripted ? kScriptDt : std::min(wall_dt, 0.1);
      if (script)
        for (const ScriptEvent& e : script->due(sim_time)) run_event(e);
      shortcuts();
      simulate(dt);
      sim_time += dt;
      if (opt.autopilot && !script && autopilot.finished && std::fabs(car.speed) < 0.05) finish_autopilot();
      if (script && script->done() && !screenshot_pending) quit = true;
      if (scripted && sim_time > opt.max_seconds) {
        std::fprintf(stderr, "icube-view: error: the session passed --max-seconds %.0f\n", opt.max_seconds);
        ++failures;
        quit = true;
      }
      update_cars();
      adapt_resolution();

      if (!presenter.begin_frame()) continue;
      ImGui_ImplVulkan_NewFrame();
      ImGui_ImplGlfw_NewFrame();
      ImGui::NewFrame();
      ui();
      ImGui::Render();
      const VkExtent2D ext = presenter.extent();
      const uint32_t w = std::max(1u, static_cast<uint32_t>(std::lround(ext.width * eff_scale)));
      const uint32_t h = std::max(1u, static_cast<uint32_t>(std::lround(ext.height * eff_scale)));
      if (have_world) {
        last_cam = view_camera(w, h);
        renderer.record(presenter.cmd(), overlay->world(), last_cam, shade);
        presenter.end_frame(&renderer.rgba(), w, h, ImGui::GetDrawData());
      } else {
        presenter.end_frame(nullptr, 0, 0, ImGui::GetDrawData());
      }
      if (screenshot_pending && have_world) take_screenshot();
      screenshot_pending = false;
      ++frame;
      if (opt.frames > 0 && frame >= opt.frames) break;
    }
    presenter.wait();
    return failures;
  }

  void finish_autopilot() {
    if (recorder.continuous()) {
      recorder.stop_continuous();
      end_pass();
      save(opt.record_out);
    }
    presenter.wait();
    if (have_world) {
      screenshot_target = opt.screenshot_out;
      take_screenshot();
    }
    quit = true;
  }
};

}  // namespace
}  // namespace icube::viewer

int main(int argc, char** argv) {
  using namespace icube;
  viewer::Options o;
  CLI::App app{"InfiniCube-VK viewer: drive or fly through a voxel world, record and replay camera trajectories",
               "icube-view"};
  app.add_option("input", o.input, "World file (.icw) or an output folder holding world.icw (+ scene.json)");
  app.add_option("--scene", o.scene_path, "Scene (icube JSON, Waymo TFRecord, OpenDRIVE): ego track, cars, camera; "
                                          "without a world, its world is built with the procedural prior");
  app.add_option("--frames", o.frames, "Close after this many frames (0 = run until closed)");
  app.add_option("--size", o.width, "Window width (height follows 16:9 unless --height)");
  app.add_option("--height", o.height, "Window height");
  app.add_option("--scale", o.scale, "Resolution scale of the view (0.25..1)")->check(CLI::Range(0.25, 1.0));
  app.add_flag("--adaptive", o.adaptive, "Adaptive resolution while moving (towards --target-ms)");
  app.add_option("--target-ms", o.target_ms, "Frame-time target of the adaptive resolution");
  app.add_option("--mode", o.mode, "Render mode")->check(CLI::IsMember({"shaded", "semantic", "depth", "instance", "coords"}));
  app.add_option("--vfov", o.vfov, "Vertical field of view in degrees (0 = the target camera's)");
  app.add_option("--frames-per-pass", o.interp_frames, "Interpolated frames per saved pass")->check(CLI::Range(2, 100000));
  app.add_option("--script", o.script, "Scripted session: timed key events and commands (viewer/script.h); exits at its end");
  app.add_flag("--autopilot", o.autopilot, "Drive the scene's ego track; without --script: record it, save, screenshot, exit");
  app.add_option("--record-out", o.record_out, "Where 'save' writes the .npy (JSON per pass next to it)");
  app.add_option("--screenshot-out", o.screenshot_out, "Where 'screenshot' writes the PNG");
  app.add_option("--load", o.load, "Trajectory (.npy [N,4,4]/[P,N,4,4] or JSON) to replay");
  app.add_option("--max-seconds", o.max_seconds, "Scripted runs fail after this many simulated seconds");
  app.add_flag("--stats", o.stats, "Print frame-time percentiles at exit");
  app.add_flag("!--no-vsync", o.vsync, "Present without waiting for vblank (mailbox/immediate) for measurements");
  app.add_option("--verify", o.verify, "No window: check a saved trajectory (shape, forward progress, camera "
                                      "height above the input world's ground) and exit 0 / 1");
  app.add_option("--expect-passes", o.expect_passes, "With --verify: the number of passes expected (0 = any)");
  bool height_given = false;
  app.callback([&] { height_given = app.count("--height") > 0; });
  CLI11_PARSE(app, argc, argv);
  if (!height_given) o.height = o.width * 9 / 16;

  if (!o.verify.empty()) {
    try {
      const std::vector<viewer::Pass> passes = viewer::load_passes(o.verify);
      std::optional<world::VoxelGrid> grid;
      std::string world_path = o.input;
      if (!world_path.empty() && std::filesystem::is_directory(world_path)) world_path += "/world.icw";
      if (!world_path.empty()) grid = world::load_world(world_path);
      viewer::PassCheckOptions co;
      co.passes = o.expect_passes;
      co.frames = static_cast<size_t>(o.interp_frames);
      co.camera_height = scene::kWaymoFrontMount.z;
      const std::vector<std::string> bad = viewer::check_passes(passes, grid ? &*grid : nullptr, co);
      std::printf("icube-view: %s: %zu pass(es) x %zu poses%s\n", o.verify.c_str(), passes.size(),
                  passes.empty() ? size_t{0} : passes[0].size(), grid ? ", heights checked on the world" : "");
      for (const std::string& b : bad) std::fprintf(stderr, "icube-view: verify: %s\n", b.c_str());
      std::printf("icube-view: verify %s\n", bad.empty() ? "ok" : "FAILED");
      return bad.empty() ? 0 : 1;
    } catch (const std::exception& e) {
      std::fprintf(stderr, "icube-view: error: %s\n", e.what());
      return 1;
    }
  }
  if (!glfwInit()) {
    std::fprintf(stderr, "icube-view: error: cannot initialise GLFW (no display? set DISPLAY or run under xvfb-run)\n");
    return 1;
  }
  if (!glfwVulkanSupported()) {
    std::fprintf(stderr, "icube-view: error: GLFW finds no Vulkan loader\n");
    glfwTerminate();
    return 1;
  }
  int rc = 0;
  GLFWwindow* window = nullptr;
  bool imgui_glfw = false;
  try {
    gpu::ContextOptions opts = gpu::ContextOptions::from_env();
    uint32_t count = 0;
    const char** exts = glfwGetRequiredInstanceExtensions(&count);
    opts.extra_instance_extensions.assign(exts, exts + count);
    opts.extra_device_extensions.push_back(VK_KHR_SWAPCHAIN_EXTENSION_NAME);
    opts.headless = false;
    gpu::Context ctx(opts);

    glfwWindowHint(GLFW_CLIENT_API, GLFW_NO_API);
    window = glfwCreateWindow(o.width, o.height, "icube-view", nullptr, nullptr);
    if (!window) throw std::runtime_error("cannot create a window");
    IMGUI_CHECKVERSION();
    ImGui::CreateContext();
    ImGui::GetIO().IniFilename = nullptr;
    ImGui::StyleColorsDark();
    ImGui_ImplGlfw_InitForVulkan(window, true);
    imgui_glfw = true;
    {
      viewer::Viewer v(o, ctx, window);
      glfwSetWindowTitle(window, ("icube-view - " + ctx.info().name).c_str());
      v.load();
      if (!o.script.empty()) {
        v.script.emplace(viewer::load_script(o.script));
        v.scripted = true;
      }
      if (o.autopilot) {
        v.scripted = true;
        v.autopilot_on = !v.autopilot.path.empty();
        if (!v.autopilot_on) throw std::runtime_error("--autopilot needs a scene with an ego track (--scene)");
        if (o.script.empty()) v.recorder.start_continuous(0.0);
      }
      std::printf("icube-view: %s on %s, %dx%d, presentation %s\n", v.world_name.c_str(), ctx.info().name.c_str(),
                  o.width, o.height, v.presenter.present_mode_name());
      rc = v.run() > 0 ? 1 : 0;
      if (ctx.validation_enabled() && ctx.message_count() > 0) {
        std::fprintf(stderr, "icube-view: error: %llu validation message(s)\n",
                     static_cast<unsigned long long>(ctx.message_count()));
        rc = 1;
      }
      if (o.stats) {
        std::printf("icube-view: stats %dx%d scale %.2f%s: %s\n", o.width, o.height, o.scale,
                    o.adaptive ? " adaptive" : "", v.stats.summary().c_str());
      }
    }
    ImGui_ImplGlfw_Shutdown();
    imgui_glfw = false;
    ImGui::DestroyContext();
    glfwDestroyWindow(window);
    window = nullptr;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "icube-view: error: %s\n", e.what());
    rc = 1;
  }
  if (imgui_glfw) {
    ImGui_ImplGlfw_Shutdown();
    ImGui::DestroyContext();
  }
  if (window) glfwDestroyWindow(window);
  glfwTerminate();
  return rc;
}

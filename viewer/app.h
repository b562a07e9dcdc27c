// icube-view's application state and the jobs it does each frame. The methods
// live in one file per job:
//   app_load.cpp    world / scene loading, teleport (teleport.h does the placing)
//   app_input.cpp   keyboard, mouse and gamepad: drive input, free fly, shortcuts
//   app_sim.cpp     simulation step, camera poses, the cars shown, adaptive resolution
//   app_record.cpp  recording, save / load, screenshots and the headless comparison
//   app_script.cpp  --script events
//   app_ui.cpp      the Dear ImGui panels and the path preview
//   app_frame.cpp   the frame loop
// The Gaussian view of a package (icube generate) is gaussian_view.h.
// Window and Vulkan set-up are in viewer_main.cpp, command-line options in options.h.
#pragma once

#include "gaussian_view.h"
#include "options.h"
#include "presenter.h"
#include "recorder.h"
#include "residency.h"
#include "screenshot_check.h"
#include "script.h"
#include "teleport.h"
#include "vehicle.h"
#include "view_renderer.h"

#include "gpu/context.h"
#include "render/buffers/frame_scene.h"
#include "render/buffers/overlay_world.h"
#include "world/mesh_voxelize.h"

#include <deque>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

namespace icube::viewer {

inline constexpr double kScriptDt = 1.0 / 30.0;  // simulated seconds per frame in scripted / autopilot runs
inline constexpr double kPi = 3.14159265358979323846;
// Worlds with more bricks than fit one GPU world get a residency radius by default (--resident-radius).
inline constexpr size_t kAutoResidencyBricks = kMaxResidentBricks;
inline constexpr double kAutoResidencyRadius = 150.0;  // m
// Adaptive resolution never renders below this scale (the panel's and the script's minimum too).
inline constexpr double kMinAdaptiveScale = 0.25;
// The Gaussian view draws its still level of detail once the view has not changed for this long (s).
inline constexpr double kStillAfter = 0.3;

enum class Control { Drive, Fly, Replay };

struct App {
  App(const Options& o, gpu::Context& c, GLFWwindow* w);

  Options opt;
  gpu::Context& ctx;
  GLFWwindow* window;
  Presenter presenter;
  ViewRenderer renderer;

  // Content.
  world::VoxelGrid grid;  // the whole static world (CPU; ground following and teleport see it)
  world::IjkBounds grid_bounds;  // grid.bounds() (the world panel's extent), computed at load
  bool have_world = false;
  std::optional<scene::Scene> scene;
  std::unique_ptr<Residency> residency;  // the static world (near the camera) on the GPU + the cars
  ResidentWorld& gpu_world() { return residency->world(); }
  world::TriangleMesh car_mesh;
  render::CarVoxelCache car_cache;
  int time_index = 0, shown_time_index = -1;
  static constexpr uint32_t kOwnInstance = 9999;  // our car: below the dynamic ids, above static ones
  static constexpr double kOwnLength = 4.6, kOwnWidth = 2.0, kOwnHeight = 1.6;  // m: our car's box
  std::vector<render::CarCell> scene_cells, own_cells;
  world::BoxVoxelization own_box;
  bool own_shown = false;
  glm::dvec4 own_pose_shown{0.0};
  bool play_time = false;
  double time_accum = 0.0;
  scene::Camera target_cam;
  std::string world_name = "(none)";
  // A package's (or a splat scene's) Gaussians, drawn instead of the voxels while show_gaussians.
  std::unique_ptr<GaussianView> gauss;
  bool show_gaussians = false;
  double view_changed_at = -1e9;  // sim_time of the last change of the Gaussian view's pose or time
  glm::dmat4 last_view_pose{0.0};
  int last_view_time = -1;
  std::string package_dir;  // the package folder opened, if any
  std::vector<TeleportTarget> map_targets, chunk_targets;

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
  bool show_ui = true;  // F1 hides the panels

  // Recording / replay.
  Recorder recorder;
  int interp_frames = kDefaultInterpolatedFrames;
  std::vector<Pass> replay;
  int replay_pass = 0;
  double replay_t = 0.0;
  char out_path[512] = {};
  char load_path[512] = {};
  char shot_path[512] = {};
  char teleport_filter[128] = {};
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
  // Per-frame parts (--stats, p50 each): host work on the main thread (simulation + script, residency,
  // cars, ImGui panels, recording the compute), the presenter's calls (waiting for the previous
  // frame, acquire, submit, present) and the device's timestamps (compute, copy to the swapchain, UI pass).
  // The Gaussian view draws in the rasterizer's own submissions: gpu_compute then holds only the
  // RGBA8 conversion, and the draw is in splat_moving / splat_still (wall clock).
  struct FrameParts {
    FrameStats sim, residency, cars, ui, record, fence, acquire, submit, present, gpu_compute, gpu_copy, gpu_ui;
    FrameStats gpu_compute_sliced;  // compute of the frames right after a residency slice (occupancy masks rebuilt)
    FrameStats scale;  // the render scale used (adaptive resolution)
    FrameStats splat_moving, splat_still;  // Gaussian view: host wall clock of each drawn view (assembly excluded)
    FrameStats splat_drawn, splat_assemble;  // Gaussian view: Gaussians and assembly ms of each drawn view
    std::string summary() const;
    std::string gaussian_summary() const;
  } parts;
  std::deque<float> frame_graph;
  double last_frame_ms = 0.0, avg_ms = 16.0;
  render::Camera last_cam;

  // app_load.cpp
  void load();
  void teleport(const std::string& where);  // "ego", "origin", "chunk N", "feature N" or a feature label
  void teleport_to(const TeleportTarget& t);
  void after_teleport();

  // app_input.cpp
  bool held(const std::string& k) const;
  bool pressed(int key);
  void shortcuts();
  VehicleInput drive_input();
  void fly_update(double dt);
  bool moving() const;

  // app_sim.cpp
  void simulate(double dt);
  // Time indices the time slider covers: the scene's states, else the Gaussians' frames (0: none).
  int timeline_frames() const;
  bool gaussian_mode() const { return show_gaussians && gauss; }
  GaussianDetail gaussian_detail() const;
  // What the presenter shows: the voxel view's or the Gaussian view's RGBA8 and its size.
  const gpu::Buffer* view_rgba() const;
  uint32_t view_width() const;
  uint32_t view_height() const;
  glm::dmat4 recorded_pose() const;
  glm::dmat4 replay_pose() const;
  glm::dmat4 view_pose() const;
  render::Camera view_camera(uint32_t w, uint32_t h) const;
  void update_cars();
  void apply_cars();  // scene_cells + own_cells into the GPU world
  // Our car where the view shows it (chase and fly, with a world to drive on): its box (the voxel
  // overlay and the Gaussian view both place the car mesh in it).
  bool own_car_visible() const;
  scene::BoxState own_car_box() const;
  void update_residency();
  void adapt_resolution();

  // app_record.cpp
  void toggle_continuous();
  void keyframe();
  void end_pass();
  void save(const std::string& path_in);
  void load_recording(const std::string& path);
  void request_screenshot(const std::string& path);
  void take_screenshot();
  void compare_with_headless(const std::vector<uint8_t>& px);
  void frame_shot(const std::string& path, size_t pass, size_t frame);
  void gaussian_frame_shot(const std::string& path, size_t pass, size_t frame);
  render::PinholeIntrinsics target_intrinsics() const;
  void finish_autopilot();

  // app_script.cpp
  void run_event(const ScriptEvent& e);

  // app_ui.cpp
  void ui();
  void chunk_panel();
  void view_panel();
  void gaussian_panel();
  void world_panel();
  void drive_panel();
  void teleport_panel();
  void record_panel();
  void draw_paths();

  // app_frame.cpp
  int run();
};

}  // namespace icube::viewer

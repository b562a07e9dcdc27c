// icube-view: loading the world / scene and teleporting; see app.h.
#include "app.h"

#include "render/buffers/trajectory.h"
#include "scene/frames.h"
#include "scene/package_layout.h"
#include "scene/scene_load.h"
#include "world/car_mesh.h"
#include "world/procedural/procedural_prior.h"
#include "world/world_build.h"
#include "world/world_file.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>

namespace icube::viewer {

App::App(const Options& o, gpu::Context& c, GLFWwindow* w)
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

namespace {

// A file holding Gaussians alone: a 3DGS .ply / .splat or an icube-splat-scene .json.
bool is_gaussian_file(const std::filesystem::path& p) {
  const std::string ext = p.extension().string();
  if (ext == ".ply" || ext == ".splat") return true;
  if (ext != ".json") return false;
  std::ifstream f(p);
  std::string head(4096, '\0');
  f.read(head.data(), static_cast<std::streamsize>(head.size()));
  head.resize(static_cast<size_t>(f.gcount()));
  return head.find(splat::kSplatSceneFormat) != std::string::npos;
}

}  // namespace

void App::load() {
  namespace fs = std::filesystem;
  std::string world_path = opt.input, scene_path = opt.scene_path, splat_path, sky_path;
  if (!world_path.empty() && fs::is_directory(world_path)) {
    const scene::PackageLayout dir(world_path);  // a package, or a folder laid out as one
    world_path = dir.world().string();
    if (scene_path.empty() && fs::exists(dir.scene())) scene_path = dir.scene().string();
    if (fs::exists(dir.splat_scene())) {  // an icube generate package
      package_dir = dir.root().string();
      splat_path = dir.splat_scene().string();
      if (fs::exists(dir.sky())) sky_path = dir.sky().string();
    }
  } else if (!world_path.empty() && is_gaussian_file(world_path)) {
    splat_path = world_path;
    world_path.clear();
    const fs::path sky = fs::path(splat_path).parent_path() / scene::PackageLayout::kSky;
    if (fs::exists(sky)) sky_path = sky.string();
  }
  if (!scene_path.empty()) {
    scene = scene::load_scene(scene_path);
    if (!scene->cameras.empty() && scene->cameras[0].fy > 0.0) target_cam = scene->cameras[0];
  }
  if (!package_dir.empty() && fs::exists(scene::PackageLayout(package_dir).trajectory())) {
    // The camera the package's frames were rendered with is the one to record for.
    const render::TrajectoryFile tf = render::load_trajectory(scene::PackageLayout(package_dir).trajectory().string(), 0);
    if (tf.camera) {
      target_cam.fx = tf.camera->fx;
      target_cam.fy = tf.camera->fy;
      target_cam.cx = tf.camera->cx;
      target_cam.cy = tf.camera->cy;
      target_cam.width = tf.camera->width;
      target_cam.height = tf.camera->height;
    }
  }
  if (!splat_path.empty()) {
    std::printf("icube-view: loading the Gaussians of %s...\n", splat_path.c_str());
    std::fflush(stdout);
    GaussianViewOptions go;
    if (opt.moving_lod.size() == 2) {
      go.moving.coarse_distance = opt.moving_lod[0];
      go.moving.max_distance = opt.moving_lod[1];
    }
    if (opt.still_lod.size() == 2) {
      go.still.coarse_distance = opt.still_lod[0];
      go.still.max_distance = opt.still_lod[1];
    }
    if (opt.chunk_size > 0.0) go.chunking.chunk_size = opt.chunk_size;
    gauss = std::make_unique<GaussianView>(ctx, splat_path, sky_path, go);
    const GaussianViewStats& gs = gauss->stats();
    std::printf("icube-view: %zu static Gaussians in %zu chunks (coarse level %zu), %zu moving objects over %zu "
                "frames, %.0f MiB on the GPU, loaded in %.1f s\n",
                gs.static_gaussians, gs.chunks, gs.coarse_gaussians, gs.objects, gauss->frames(),
                double(gs.resident_bytes) / (1024.0 * 1024.0), gs.load_s);
    show_gaussians = opt.view != "voxels";
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
  if (opt.view == "gaussians" && !gauss)
    throw std::invalid_argument("--view gaussians: " + (opt.input.empty() ? std::string("no input") : opt.input) +
                                " holds no Gaussians (a package, a splat scene .json or a .ply / .splat)");
  if (have_world) {
    car_mesh = world::builtin_car_mesh();
    if (gauss) gauss->set_own_car(car_mesh, kOwnLength, kOwnWidth, kOwnHeight);
    if (scene) grid = render::make_static_world(grid, *scene, 0, car_mesh);  // ground following sees what is drawn
    double radius = opt.resident_radius;
    if (radius < 0.0) radius = grid.brick_count() > kAutoResidencyBricks ? kAutoResidencyRadius : 0.0;
    if (radius == 0.0 && grid.brick_count() > kAutoResidencyBricks) {
      std::fprintf(stderr, "icube-view: warning: %zu bricks do not fit one GPU world; residency radius %.0f m\n",
                   grid.brick_count(), kAutoResidencyRadius);
      radius = kAutoResidencyRadius;
    }
    residency = std::make_unique<Residency>(ctx, grid, radius);
    chunk_targets = viewer::chunk_targets(grid);
    grid_bounds = grid.bounds();  // a walk over every brick: once, not per frame in the world panel
  }
  if (scene) {
    autopilot.path = ego_path(*scene);
    map_targets = viewer::map_targets(*scene);
  }
  teleport(scene && !scene->ego.empty() ? "ego" : "origin");
  if (residency && residency->radius() > 0.0) {
    residency->update(glm::dvec2(view_pose()[3]));  // the first resident set, before the first frame
    residency->finish();
    std::printf("icube-view: residency radius %.0f m: %zu of %zu bricks resident (upload %.0f ms)\n",
                residency->radius(), residency->stats().resident_bricks, grid.brick_count(),
                residency->stats().last_upload_ms);
  }
  if (!have_world && gauss) {  // Gaussians alone: nothing else to show, no ground to drive on
    show_gaussians = true;
    control = Control::Fly;
  }
  if (!opt.load.empty()) load_recording(opt.load);
}

void App::teleport(const std::string& where) {
  auto indexed = [&](const std::string& prefix, const std::vector<TeleportTarget>& list) -> const TeleportTarget* {
    if (where.rfind(prefix, 0) != 0) return nullptr;
    const size_t i = std::stoul(where.substr(prefix.size()));
    if (i >= list.size()) throw std::invalid_argument("teleport: no " + where + " (" + std::to_string(list.size()) + ")");
    return &list[i];
  };
  if (const TeleportTarget* t = indexed("chunk ", chunk_targets)) return teleport_to(*t);
  if (const TeleportTarget* t = indexed("feature ", map_targets)) return teleport_to(*t);
  for (const TeleportTarget& t : map_targets)
    if (t.label == where) return teleport_to(t);
  if (where == "ego" && scene) {
    for (const scene::EgoPose& e : scene->ego)
      if (e.valid) {
        car = vehicle_from_ego(e.ego_to_world);
        break;
      }
    autopilot.progress = 0;
    autopilot.finished = false;
  } else if (where == "ego" || where == "origin") {
    if (!have_world && gauss) {
      car = VehicleState{};
      car.position = gauss->centre();
    } else if (have_world) {
      const world::IjkBounds b = grid.bounds();
      const glm::dvec3 c = 0.5 * (grid.ijk_to_world(b.min) + grid.ijk_to_world(b.max));
      car = VehicleState{};
      car.position = c;
    }
  } else {
    throw std::invalid_argument("teleport: unknown target '" + where + "' (ego, origin, chunk N, feature N or a label)");
  }
  car.speed = 0.0;
  ground.zero_z = car.position.z;
  if (have_world) {
    const double top = grid.origin().z + (grid.bounds().max.z + 2) * grid.voxel_size();
    if (!settle_vehicle(car, limits, grid, ground, std::max(top, car.position.z + 2.0)) && !scene) car.position.z = 0.0;
    ground.zero_z = car.position.z;
  }
  after_teleport();
}

void App::teleport_to(const TeleportTarget& t) {
  if (!have_world) return;
  if (!ground.zero_height) ground.zero_z = t.position.z;
  if (!place_at_target(car, t, grid, limits, ground, scene ? &*scene : nullptr)) {
    status = "teleport: no ground at " + t.label;
    if (scripted) {
      std::fprintf(stderr, "icube-view: error: %s\n", status.c_str());
      ++failures;
    }
    return;
  }
  if (!ground.zero_height) ground.zero_z = car.position.z;
  if (t.kind == TargetKind::EgoStart) {
    autopilot.progress = 0;
    autopilot.finished = false;
  }
  char where[160];
  std::snprintf(where, sizeof where, " (car at %.1f %.1f %.1f m, heading %.0f deg)", car.position.x, car.position.y,
                car.position.z, car.yaw * 180.0 / kPi);
  status = "teleported to " + t.label + where;
  after_teleport();
}

void App::after_teleport() {
  if (control == Control::Replay) control = Control::Drive;
  fly.position = car.position + glm::dvec3(0, 0, 6.0) - 8.0 * glm::dvec3(std::cos(car.yaw), std::sin(car.yaw), 0);
  fly.yaw = car.yaw;
  fly.pitch = -0.25;
}

}  // namespace icube::viewer

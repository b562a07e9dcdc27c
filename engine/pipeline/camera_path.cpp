// The camera path of the rendering commands; see camera_path.h.
#include "pipeline/camera_path.h"

#include "scene/frames.h"
#include "scene/scene_load.h"

#include <cstdio>
#include <stdexcept>

namespace icube::pipeline {

size_t CameraPath::total_frames() const {
  size_t n = 0;
  for (const auto& p : passes) n += p.size();
  return n;
}

CameraPath resolve_camera_path(const CameraPathArgs& a, scene::Diagnostics& diag) {
  if (!a.camera.empty() && !a.preset.empty()) throw std::invalid_argument("give --camera or --camera-preset, not both");
  std::optional<render::PinholeIntrinsics> cli_K;
  if (!a.camera.empty()) cli_K = render::parse_camera(a.camera);
  std::optional<scene::Camera> preset;
  if (!a.preset.empty()) preset = render::camera_preset(a.preset);
  std::optional<render::FrameRange> range;
  if (!a.frames.empty()) range = render::parse_frame_range(a.frames);

  CameraPath out;
  if (!a.scene.empty()) {
    scene::LoadOptions lo;
    lo.waymo_selector = a.record;
    out.scene = scene::load_scene(a.scene, lo, &diag);
    if (scene::tracks_unclassified(*out.scene)) scene::classify_tracks(*out.scene);
  }
  const std::optional<scene::Scene>& sc = out.scene;
  std::optional<render::PinholeIntrinsics> file_K;
  if (a.route_m > 0.0 && !a.trajectory.empty()) throw std::invalid_argument("give --route or --trajectory, not both");
  if (a.route_m > 0.0) {
    if (!sc) throw std::invalid_argument("--route needs --scene (its lanes)");
    scene::RouteOptions ro = a.route;
    ro.length_m = a.route_m;
    if (a.route_start_given) ro.start_lane = a.route_start_lane;
    scene::Camera cam = !sc->cameras.empty() ? sc->cameras[0] : scene::waymo_front_camera();
    if (preset) cam = *preset;
    scene::RouteReport rep;
    out.passes.push_back(render::route_trajectory(*sc, cam, ro, &rep));
    for (const std::string& n : rep.notes) diag.warn(a.scene, "route", n);
    std::fprintf(stderr, "route: %.1f m over %zu lane(s), %zu poses%s\n", rep.length_m, rep.lanes.size(), rep.poses,
                 rep.dead_end ? " (dead end)" : "");
    if (out.passes[0].size() == 0) throw scene::InputError(a.scene, "route", "the route has no pose");
  } else if (!a.trajectory.empty()) {
    render::TrajectoryFile tf = render::load_trajectory(a.trajectory, sc ? sc->timestamps.size() : 0);
    out.passes = std::move(tf.passes);
    file_K = tf.camera;
  } else {
    if (!sc) throw std::invalid_argument("give --scene (its ego track is the trajectory) or --trajectory FILE");
    if (sc->ego.empty()) throw scene::InputError(a.scene, "ego", "the scene has no ego trajectory; give --trajectory FILE");
    scene::Camera cam = !sc->cameras.empty() ? sc->cameras[0] : scene::waymo_front_camera();
    if (preset) cam = *preset;
    out.passes.push_back(render::ego_trajectory(*sc, cam));
    if (out.passes[0].size() == 0) throw scene::InputError(a.scene, "ego", "no valid ego pose");
  }
  if (cli_K) out.K = *cli_K;
  else if (preset) out.K = render::intrinsics_of(*preset);
  else if (file_K) out.K = *file_K;
  else if (sc && !sc->cameras.empty()) out.K = render::intrinsics_of(sc->cameras[0]);
  else out.K = render::intrinsics_of(scene::waymo_front_camera());
  if (range)
    for (auto& p : out.passes) p = render::select_frames(p, *range);
  return out;
}

}  // namespace icube::pipeline

// The camera-path options of the rendering commands; see camera_path_options.h.
#include "camera_path_options.h"

namespace icube::tools {

void add_camera_path_options(CLI::App* cmd, pipeline::CameraPathArgs& a) {
  cmd->add_option("--scene", a.scene, "Scene: ego trajectory, camera, static and dynamic cars")->type_name("SCENE");
  cmd->add_option("--record", a.record, "Waymo TFRecord only: which record, by index or scenario id")->type_name("SEL");
  cmd->add_option("--trajectory", a.trajectory,
                  "Camera poses: .npy [N,4,4] or [P,N,4,4] OpenCV camera-to-world in the scene's world frame, or "
                  "icube-trajectory JSON")
      ->type_name("FILE");
  cmd->add_option("--route", a.route_m,
                  "Trajectory: a seeded drive of this many metres along the scene's lanes (instead of its ego track)")
      ->type_name("METRES")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--route-seed", a.route.seed, "Seed of --route's start lane and fork choices")
      ->type_name("N")
      ->capture_default_str();
  cmd->add_option("--route-speed", a.route.speed_mps, "Speed of --route in m/s (poses at 10 Hz)")
      ->type_name("MPS")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  cmd->add_option_function<int64_t>(
         "--route-start-lane",
         [&a](const int64_t& id) {
           a.route_start_lane = id;
           a.route_start_given = true;
         },
         "Lane id --route starts on (default: chosen by the seed)")
      ->type_name("ID");
  cmd->add_option("--camera", a.camera, "Pinhole intrinsics in pixels")->type_name("fx,fy,cx,cy,w,h");
  cmd->add_option("--camera-preset", a.preset, "waymo-front-480p: Waymo FRONT rescaled to 832x480")->type_name("NAME");
  cmd->add_option("--frames", a.frames, "Frames [A, B) of the trajectory, every S-th with A:B:S (A:, :B, ::S and A also work)")
      ->type_name("A:B[:S]");
}

}  // namespace icube::tools

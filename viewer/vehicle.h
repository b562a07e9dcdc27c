// The viewer's car and cameras (CPU only; library icube_viewer_core).
//
// Kinematic bicycle model about the rear axle in the scene's world frame
// (metres, z up): x' = v cos(yaw), y' = v sin(yaw), yaw' = v tan(steer) / L.
// Inputs are normalised (throttle, brake in [0, 1], steer in [-1, 1], + = left);
// the model applies acceleration, braking, drag, a steering-rate limit and a
// speed-dependent steering limit (lateral acceleration <= max_lateral). Holding
// brake at a standstill engages reverse (throttle then drives backwards).
// The car follows the ground: a downward ray query (a column walk through the
// voxel grid from step_height above the car) at the rear and front axles gives
// z and pitch; "always zero height" (InfiniCube's option) pins z instead.
// Cameras: the recorded camera is the scene's front camera (camera_to_ego,
// FLU) on the car; the view can be that dash camera or a chase camera behind.
// Tests: tests/viewer/test_viewer.cpp.
#pragma once

#include "scene/scene.h"
#include "world/voxel_grid.h"

#include <glm/glm.hpp>

#include <optional>
#include <vector>

namespace icube::viewer {

struct VehicleLimits {
  double wheelbase = 2.8;         // m
  double max_accel = 3.5;         // m/s^2 at full throttle
  double max_brake = 8.0;         // m/s^2 at full brake
  double drag = 0.0015;           // m^-1: deceleration drag · v^2
  double rolling = 0.25;          // m/s^2 without throttle
  double max_speed = 30.0;        // m/s forward
  double max_reverse = 5.0;       // m/s backwards
  double max_steer = 0.6;         // rad at the wheels
  double steer_rate = 1.6;        // rad/s
  double max_lateral = 7.0;       // m/s^2: limits the steer angle at speed
};

struct VehicleInput {
  double throttle = 0.0, brake = 0.0, steer = 0.0;
};

struct VehicleState {
  glm::dvec3 position{0.0};  // rear axle on the ground, world
  double yaw = 0.0;          // heading of +x (forward), radians from world +x
  double pitch = 0.0;        // nose up positive
  double speed = 0.0;        // m/s along the heading (negative = reversing)
  double steer = 0.0;        // current wheel angle, rad
  bool reversing = false;
  double odometer = 0.0;     // metres driven (absolute)
};

// Height of the ground under (x, y): the top of the first solid voxel (not a
// vehicle, person, bicycle, pole or sign) found walking down from z_from to
// z_from - max_drop. nullopt when there is none.
std::optional<double> ground_height(const world::VoxelGrid& grid, double x, double y, double z_from,
                                    double max_drop = 8.0);

struct GroundOptions {
  bool follow = true;           // false: keep z
  bool zero_height = false;     // pin z to zero_z ("always zero height")
  double zero_z = 0.0;
  double step_height = 1.0;     // m the car can climb per query
};

// Advances the state by dt with the input; follows the ground of `grid` when given.
void step_vehicle(VehicleState& s, const VehicleInput& in, double dt, const VehicleLimits& lim,
                  const world::VoxelGrid* grid, const GroundOptions& ground);

// Places the car on the ground at its (x, y) (pitch too); returns false when no ground is found.
bool settle_vehicle(VehicleState& s, const VehicleLimits& lim, const world::VoxelGrid& grid,
                    const GroundOptions& ground, double search_from_z);

// Ego (FLU) to world of the car: T(position) Rz(yaw) Ry(-pitch) (pitch nose up).
glm::dmat4 vehicle_to_world(const VehicleState& s);
// The camera on the car (camera_to_ego FLU) as an OpenCV camera-to-world pose.
glm::dmat4 dash_camera_c2w(const VehicleState& s, const scene::Camera& cam);
// A chase camera `distance` behind and `height` above the car, looking at a point 2 m above the rear axle.
glm::dmat4 chase_camera_c2w(const VehicleState& s, double distance = 9.0, double height = 3.5);

// Free-fly camera: position, yaw (from world +x), pitch (up positive); OpenCV c2w.
struct FlyCamera {
  glm::dvec3 position{0.0};
  double yaw = 0.0, pitch = 0.0;
};
glm::dmat4 fly_camera_c2w(const FlyCamera& f);
// Forward / left unit vectors of a fly camera (forward includes pitch).
glm::dvec3 fly_forward(const FlyCamera& f);
glm::dvec3 fly_left(const FlyCamera& f);
// OpenCV c2w looking from `eye` to `target` with world z up.
glm::dmat4 look_at_c2w(const glm::dvec3& eye, const glm::dvec3& target);

// Yaw (heading) and position of an ego pose's FLU frame.
VehicleState vehicle_from_ego(const glm::dmat4& ego_to_world);

// Autopilot: pure pursuit along a path (the scene's ego track, x y in world
// metres) at a target speed, slower where the path turns (lateral
// acceleration <= 2 m/s^2, planned 40 m ahead), braking to a stop at the end. `progress` is the
// index of the nearest path point, searched forwards only, so it never goes back.
struct Autopilot {
  std::vector<glm::dvec2> path;
  double target_speed = 10.0;  // m/s
  double lookahead = 4.0;      // m (+ 0.25 s of travel)
  size_t progress = 0;
  bool finished = false;
};
VehicleInput autopilot_input(Autopilot& ap, const VehicleState& s, const VehicleLimits& lim);
// Path points of the valid ego poses, with consecutive points closer than `min_spacing` dropped.
std::vector<glm::dvec2> ego_path(const scene::Scene& s, double min_spacing = 0.5);

}  // namespace icube::viewer

// One LiDAR sweep cast against the voxel world with the voxel ray caster
// (RaycasterGpu, ray-list mode), and the conversion of its hits to returns.
//
// Rays: every (ring, column) direction of the model (lidar_model.h) rotated
// by the sensor-to-world pose, all from the sensor origin (motion during the
// sweep is ignored). Ray index = ring · columns + column.
// A ray gives a return when the caster reports a depth hit (the entry
// distance t_depth of the first run of occupied voxels at least 0.1 m long:
// InfiniCube's depth rule) with min_range <= t_depth <= max_range; anything
// else (a miss, a first surface nearer than min_range or beyond max_range)
// gives none: the sensor is not modelled as seeing past its first surface.
// The traversal stops at t_max = max_range + eps_depth + 2 voxels, enough to
// confirm a run that starts at max_range.
// Per return:
//  - range = t_depth (metres along the ray);
//  - point_sensor = range · direction (sensor frame, FLU), point_world =
//    sensor_to_world · point_sensor (double);
//  - class, instance: the semantic hit (first voxel with a >= 1 cm chord;
//    class 0 / instance 0 if the run had none, which needs a run of chords all
//    under 1 cm);
//  - intensity = reflectivity(class) · |cos(incidence)|: the incidence angle
//    between the ray and the normal of the voxel face through which the ray
//    enters the depth run (the surface the range measures; voxel faces are
//    axis-aligned in the world frame, so |cos| = |d_world[axis]|, the axis
//    being the one on whose lattice plane the entry point lies); 1 for a run
//    that starts at the sensor. Not the semantic voxel's face: with the 1 cm
//    rule that can be a side face behind a thin corner. A Lambertian model
//    without range fall-off (like range-normalised intensities), in [0, 1].
//  - ring, column.
// Reflectivity table: lidar_reflectivity(); the values are ASSUMED,
// plausible near-infrared (905 nm) diffuse reflectances by material, not
// measured: asphalt 0.15, retro-reflective paint / signs 0.7-0.9, vegetation
// 0.55, concrete and buildings 0.35-0.4, painted vehicles 0.5, people 0.35.
// Range image: `range` holds beams x columns floats (0 = no return).
// Tests: tests/render/test_lidar.cpp.
#pragma once

#include "gpu/buffer.h"
#include "gpu/context.h"
#include "render/lidar/lidar_model.h"
#include "render/raycast_gpu.h"

#include <glm/glm.hpp>

#include <cstdint>
#include <vector>

namespace icube::render {

struct LidarReturn {
  glm::vec3 sensor{0.0f};   // point in the sensor frame (FLU, metres)
  glm::dvec3 world{0.0};    // point in the world frame
  float range = 0.0f;       // metres
  float intensity = 0.0f;   // [0, 1]
  uint8_t class_id = 0;
  uint16_t instance = 0;
  uint16_t ring = 0, column = 0;
};

struct LidarScan {
  int frame_index = 0;   // the frame's number in file names
  int time_index = -1;   // scene state of the dynamic cars (-1 = none)
  glm::dmat4 sensor_to_world{1.0};
  uint32_t beams = 0, columns = 0;
  std::vector<LidarReturn> returns;  // ray order
  std::vector<float> range;          // beams · columns, row = ring; 0 = no return
};

// Per-class reflectivity in [0, 1], indexed by class id (0 for class 0 and unknown ids).
float lidar_reflectivity(uint8_t class_id);
// reflectivity(class) · |dir_world[axis]| (unit direction; axis < 0: cos = 1).
float lidar_intensity(uint8_t class_id, int axis, const glm::dvec3& dir_world);
// The axis (0-2) of the lattice plane nearest to world point p (the entry face of a run starting at p).
int lidar_entry_axis(const glm::dvec3& p, const glm::dvec3& grid_origin, double voxel_size);

RaycastOptions lidar_raycast_options(const LidarModel& m, double voxel_size);
// World rays of one sweep from the sensor-frame directions (lidar_directions).
std::vector<Ray> lidar_rays(const std::vector<glm::dvec3>& dirs_sensor, const glm::dmat4& sensor_to_world);
// Hits (ray order) to returns and the range image. Throws std::invalid_argument on a size mismatch.
// `grid_origin`, `voxel_size`: the world lattice (for the entry faces).
LidarScan lidar_scan_from_hits(const LidarModel& m, const std::vector<glm::dvec3>& dirs_sensor,
                               const glm::dmat4& sensor_to_world, const std::vector<shader::RaycastHit>& hits,
                               const glm::dvec3& grid_origin, double voxel_size);

// Casts sweeps of one model on the GPU (the hits buffer is allocated once).
class LidarCaster {
 public:
  LidarCaster(gpu::Context& ctx, const LidarModel& model);  // validates the model
  LidarScan cast(const RaycastWorld& w, const glm::dmat4& sensor_to_world);
  const LidarModel& model() const { return model_; }
  const std::vector<glm::dvec3>& directions() const { return dirs_; }
  // Accumulated timings: ray upload, dispatch (submit and wait), hit download, hits -> scan.
  double upload_s = 0.0, cast_s = 0.0, download_s = 0.0, post_s = 0.0;

 private:
  gpu::Context& ctx_;
  LidarModel model_;
  std::vector<glm::dvec3> dirs_;
  RaycasterGpu caster_;
  gpu::Buffer hits_;
};

}  // namespace icube::render

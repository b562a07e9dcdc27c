// Stage 3 for dynamic objects, without a network: each moving vehicle's
// Gaussians in its object frame, from the key frames' pixels of that vehicle
// (conventions §14: InfiniCube moves the pixels of instances >= 10000 inside
// their box into the object frame; its playback then transforms positions
// only, we place whole Gaussians with splat_scene.h's rigid placement).
//
// A pixel is a sample of object `id` when the frame's instance id is `id`
// (>= kDynamicInstanceMin) and the ray caster's hit on that frame's scene
// (the static world plus the cars of the frame's time index, as the frames
// were rendered) is a voxel of the same instance. Its hit point x (world) goes
// into the object frame, x_o = inv(object_to_world(t)) · x, with
// object_to_world = scene::box_to_world of the track's state at the frame's
// time index (scene::state_filled, as the renderers place cars). Samples are
// binned into the object frame's cells of `cell` metres (floor(x_o / cell));
// each cell sums its RGB (integers) and its points (double, in frame-then-
// pixel order: the same every run). Each cell gives one isotropic Gaussian at
// the mean point, σ = sigma_cells · cell, opacity `opacity`, the mean colour as
// SH0. The car voxels are re-voxelised in every frame (0.2 m cells at the
// car's pose), so the points of one car face spread over a cell's width;
// Gaussians of cells of `cell` metres keep the car's shape to that size.
// Tests: tests/lift/test_dynamic_lift.cpp.
#pragma once

#include "render/camera.h"
#include "scene/scene.h"
#include "shared/raycast_params.h"
#include "splat/splat_scene.h"

#include <glm/glm.hpp>

#include <cstdint>
#include <map>
#include <unordered_map>
#include <vector>

namespace icube::lift {

struct DynamicLiftOptions {
  double cell = 0.1;          // metres, object frame
  float sigma_cells = 0.6f;   // σ in cells
  float opacity = 0.95f;
  size_t min_cells = 1;       // objects with fewer seen cells are left out
};

struct ObjectCell {
  uint32_t sum_r = 0, sum_g = 0, sum_b = 0, count = 0;
  glm::dvec3 sum_point{0.0};
};

class DynamicLiftAccumulator {
 public:
  explicit DynamicLiftAccumulator(const DynamicLiftOptions& o = {}) : o_(o) {}
  // One sample of object `id`: world point, 8-bit colour, object_to_world at its frame.
  void add(uint16_t id, const glm::dvec3& world_point, const glm::dmat4& world_to_object, uint8_t r, uint8_t g,
           uint8_t b);
  // The samples of one frame: pixels whose frame instance (`instance`, W·H) is a dynamic id that
  // `world_to_object` holds and whose hit (`hits`, W·H) is the same instance. Returns the samples.
  size_t add_frame(const render::Camera& cam, render::PixelConvention pixels, const std::vector<uint8_t>& rgb,
                   const std::vector<uint16_t>& instance, const std::vector<shader::RaycastHit>& hits,
                   const std::map<uint16_t, glm::dmat4>& world_to_object);
  size_t samples() const { return samples_; }
  // One Gaussian set per object (object frame), by ascending id; cells in z, y, x order.
  std::map<uint16_t, splat::GaussianCloud> emit() const;

 private:
  DynamicLiftOptions o_;
  size_t samples_ = 0;
  struct CellHash {
    size_t operator()(const glm::ivec3& c) const;
  };
  std::map<uint16_t, std::unordered_map<glm::ivec3, ObjectCell, CellHash>> objects_;
};

// The box of each dynamic vehicle track (not the ego, instance ids from kDynamicInstanceMin) at
// `time_index`, by instance id (scene::state_filled: a track not valid there is placed at its nearest
// valid state); the states point into `s`.
std::map<uint16_t, const scene::BoxState*> dynamic_vehicle_states(const scene::Scene& s, int time_index);
// object_to_world of each of them.
std::map<uint16_t, glm::dmat4> dynamic_object_poses(const scene::Scene& s, int time_index);

}  // namespace icube::lift

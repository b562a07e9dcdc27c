// Night lights of the procedural appearance renderer, in world metres:
// - street lamps: one at the top of every pole at least 4 m tall (columns of
//   POLE voxels; neighbouring columns within 1.6 m are one pole), omni, warm
//   white (sodium-LED mix), range 6 m;
// - headlights: two per dynamic vehicle of the frame's scene state (the
//   guidance buffers' cars), 0.65 m above the box bottom at +-0.35 width of
//   the front face, aimed along the heading 4 degrees down, 35 degree cone,
//   range 10 m.
// lights_for_frame keeps the lights that can reach what a camera sees (nearest
// first, within a distance, at most a count) relative to the camera's
// reference voxel corner, as the kernel reads them.
#pragma once

#include "scene/scene.h"
#include "shared/appearance_params.h"
#include "world/voxel_grid.h"

#include <glm/glm.hpp>

#include <cstdint>
#include <vector>

namespace icube::render {

struct WorldLight {
  glm::dvec3 pos{0.0};
  double range = 6.0;
  glm::dvec3 dir{0.0};
  double cos_cut = -1.0;
  glm::vec3 intensity{0.0f};
  uint32_t kind = APPEARANCE_LIGHT_LAMP;
};

std::vector<WorldLight> street_lamps(const world::VoxelGrid& grid);
std::vector<WorldLight> headlights(const scene::Scene& s, int time_index);

std::vector<shader::AppearanceLight> lights_for_frame(const std::vector<WorldLight>& lights, const glm::dvec3& grid_origin,
                                                      double voxel_size, const glm::ivec3& ref,
                                                      const glm::dvec3& camera, size_t max_count = 48,
                                                      double max_distance_m = 150.0);

}  // namespace icube::render

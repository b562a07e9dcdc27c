// Labelled point clouds -> VoxelGrid by per-voxel majority vote.
//
// Inputs:
//   .npy  N x 4 or N x 5, <f4 or <f8: x, y, z, class[, instance]
//   .ply  ascii or binary_little_endian, element "vertex" with x, y, z
//         (float or double) and a class property named "class", "label" or
//         "semantic" (any integer or float type), optional "instance".
// Rows are numbered from 0 in errors. A row with NaN/Inf coordinates, a class
// outside 0..22 or a non-integer class/instance is a scene::InputError naming
// the row; class-0 points are ignored.
//
// Vote (conventions §2): each voxel takes the class with the most points,
// ties to the lowest class id; its instance is the most frequent instance
// among the points of the winning class, ties to the lowest id.
// Tests: tests/world/test_world_io.cpp.
#pragma once

#include "world/voxel_grid.h"

#include <glm/glm.hpp>

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace icube::world {

struct LabeledPoint {
  glm::dvec3 position{0.0};
  uint8_t class_id = 0;
  uint16_t instance = 0;
};

struct ImportStats {
  uint64_t points = 0;          // rows read
  uint64_t labelled_points = 0; // rows with class > 0
  uint64_t voxels = 0;
};

// Points are validated by the readers; `name` labels errors (a point outside the ijk range).
VoxelGrid voxelize_points(const std::vector<LabeledPoint>& points, const glm::dvec3& origin, double voxel_size,
                          const std::string& name);

std::vector<LabeledPoint> read_points_npy(const std::string& path);
std::vector<LabeledPoint> read_points_ply(const std::string& path);
// `rows` (optional) receives the vertex count including class-0 rows.
std::vector<LabeledPoint> points_from_ply_bytes(std::string_view bytes, const std::string& name,
                                                uint64_t* rows = nullptr);

// Chooses the reader by content (.npy magic or "ply\n").
VoxelGrid import_points(const std::string& path, const glm::dvec3& origin, double voxel_size = kFineVoxel,
                        ImportStats* stats = nullptr);

}  // namespace icube::world

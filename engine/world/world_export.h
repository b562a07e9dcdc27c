// Exports of a VoxelGrid for viewers and other tools (written atomically).
//
//   .ply  binary little-endian point cloud, one vertex per voxel centre:
//         float x y z relative to the world origin, uchar red green blue
//         (world::class_color), uchar class, ushort instance. The origin is in
//         the header as "comment icube_origin X Y Z" (%.17g, exact) and
//         "comment icube_voxel_size VS".
//   .glb  glTF 2.0 binary: the voxels' boundary faces, greedily merged
//         (greedy_mesh.h), one primitive per class with a flat material of
//         the class colour, no normals (glTF viewers then shade flat, which is
//         what voxel faces want); float positions relative to the origin, and the
//         single node's translation = origin (double in the JSON), so a world
//         far from (0, 0, 0) keeps its precision. Positions are float, so they
//         stay within 1 mm up to about 16 km from the origin (the PLY too).
// .nvdb is not offered: the engine does not use NanoVDB.
// Tests: tests/world/test_world_io.cpp.
#pragma once

#include "world/voxel_grid.h"

#include <cstdint>
#include <string>

namespace icube::world {

struct ExportStats {
  uint64_t points = 0;     // .ply
  uint64_t quads = 0;      // .glb
  uint64_t triangles = 0;  // .glb
  uint64_t primitives = 0; // .glb (classes present)
  size_t bytes = 0;
};

std::string world_to_ply_bytes(const VoxelGrid& grid, ExportStats* stats = nullptr);
std::string world_to_glb_bytes(const VoxelGrid& grid, ExportStats* stats = nullptr);

// By extension: ".ply" or ".glb" (case-insensitive); anything else throws std::invalid_argument.
ExportStats export_world(const VoxelGrid& grid, const std::string& path);

}  // namespace icube::world

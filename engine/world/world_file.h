// The `.icw` world file: a VoxelGrid, losslessly, in versioned little-endian binary.
//
//   offset  size  field
//   0       4     magic "ICW1"
//   4       4     uint32 version (kWorldFileVersion)
//   8       24    float64 origin x, y, z (metres)
//   32      8     float64 voxel size (metres)
//   40      8     uint64 brick count
//   48      ...   per brick, in ascending brick_key order:
//                   int32 brick x, y, z; uint64 mask[8] (bit lx + 8 ly + 64 lz);
//                   uint8 class[n] then uint16 instance[n] for the n occupied voxels in mask order
//   end-4   4     uint32 CRC32 (polynomial 0xEDB88320, zlib's) of every byte before it
//
// Saving is deterministic, so load + save reproduces a file byte for byte.
// The reader checks magic, version, CRC, sizes (a brick count is bounded by
// the file size before anything is allocated), brick coordinates, duplicate
// and empty bricks and class ids (1..22), and reports the first problem as
// scene::InputError with its byte offset. Tests: tests/world/test_world_io.cpp.
#pragma once

#include "world/voxel_grid.h"

#include <cstdint>
#include <string>
#include <string_view>

namespace icube::world {

inline constexpr uint32_t kWorldFileVersion = 1;
inline constexpr size_t kWorldHeaderBytes = 48;

// CRC-32 as in zlib/PNG (reflected 0xEDB88320, init and final xor 0xFFFFFFFF).
uint32_t crc32(std::string_view bytes, uint32_t crc = 0);

std::string world_to_bytes(const VoxelGrid& grid);
// `name` is used in error messages only.
VoxelGrid world_from_bytes(std::string_view bytes, const std::string& name);

void save_world(const VoxelGrid& grid, const std::string& path);  // atomic
VoxelGrid load_world(const std::string& path);

}  // namespace icube::world

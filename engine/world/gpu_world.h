// The VoxelGrid on the GPU (layout in shaders/shared/world_layout.h, GLSL
// lookups in shaders/world/lookup.glsl): an open-addressing hash table
// from packed brick coordinate to brick index (power-of-two capacity, load
// <= 0.5, linear probing) and one WorldBrickRecord per brick (mask, classes
// 4 per uint, instances 2 per uint). Bricks are laid out in brick_key order,
// so the same grid always gives the same buffers.
//
// Each buffer is bound whole, so brick_data is limited to one storage binding
// (maxStorageBufferRange: 128 MiB = ~83,000 bricks on lavapipe, 4 GiB on NVIDIA).
// Test: tests/world/test_world_gpu.cpp (world/probe.comp against VoxelGrid::get).
#pragma once

#include "gpu/buffer.h"
#include "shared/world_layout.h"
#include "world/voxel_grid.h"

#include <glm/glm.hpp>

#include <cstdint>
#include <vector>

namespace icube::world {

// The buffers' contents, built on the CPU.
struct GpuWorldHost {
  std::vector<shader::WorldHashEntry> table;  // capacity entries
  std::vector<uint32_t> bricks;               // WORLD_BRICK_UINTS per brick
  uint32_t table_mask = 0;                    // capacity - 1
  uint32_t brick_count = 0;
};

GpuWorldHost build_gpu_world_host(const VoxelGrid& grid);
// One brick's WorldBrickRecord as build_gpu_world_host writes it (rec: WORLD_BRICK_UINTS uints, overwritten),
// for worlds updated brick by brick (viewer/resident_world.h).
void write_brick_record(const Brick& b, uint32_t* rec);
// The CPU mirror of world_voxel() in world/lookup.glsl.
Voxel lookup_gpu_world_host(const GpuWorldHost& host, const glm::ivec3& ijk);

// Pieces of the layout for code that edits the buffers in place (render/buffers/overlay_world,
// viewer/resident_world): the table hash of a packed brick key (brick_key), whether table entry
// e holds that key, and one voxel of a brick record written (mask bit, class, instance) or read.
uint32_t brick_key_hash(uint64_t key);
bool table_entry_is(const shader::WorldHashEntry& e, uint64_t key);
void record_set_voxel(uint32_t* rec, const glm::ivec3& ijk, uint8_t cls, uint16_t inst);
Voxel record_voxel(const uint32_t* rec, const glm::ivec3& ijk);
// The slot of `key` in a table of capacity mask + 1: its entry, or the empty slot where it goes.
uint32_t find_table_slot(const std::vector<shader::WorldHashEntry>& table, uint32_t mask, uint64_t key);
// Grows `b` to hold the brick of packed key `key`.
void join_brick_bounds(IjkBounds& b, uint64_t key);

struct GpuWorld {
  gpu::Buffer brick_table;  // WorldHashEntry[capacity]
  gpu::Buffer brick_data;   // WorldBrickRecord[brick_count] (one dummy record when empty)
  uint32_t table_mask = 0;
  uint32_t brick_count = 0;
  glm::dvec3 origin{0.0};
  double voxel_size = kFineVoxel;
};

GpuWorld upload_gpu_world(gpu::Context& ctx, const VoxelGrid& grid);

// Runs world/probe.comp: (class, instance) for every query ijk.
std::vector<Voxel> probe_gpu_world(gpu::Context& ctx, const GpuWorld& world, const std::vector<glm::ivec3>& queries);

}  // namespace icube::world

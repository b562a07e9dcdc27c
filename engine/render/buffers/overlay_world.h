// The static world on the GPU once, with each frame's dynamic car cells
// patched in brick by brick (no per-frame rebuild or re-upload of the world).
//
// Layout: the world_layout.h buffers of RaycasterGpu, built here so they have
// room to spare. brick_data = the static bricks (brick_key order, uploaded
// once) followed by `overlay_capacity` free records; brick_table = a hash
// table (same hash and linear probing as gpu_world.cpp) sized for static +
// overlay bricks at load <= 0.5, kept on the host too.
// set_overlay(cells): for every brick a car cell touches, a copy of its
// static record (or an empty one) gets the cells written into it (class CAR,
// the car's instance; a car cell replaces a static voxel unless that voxel is
// a static car's cell: static ids are lower, so they win the tie) and goes to
// an overlay slot; the table entry of that brick is pointed at the slot (or a
// new entry inserted); entries of the previous frame are restored first. Per
// frame it uploads the overlay records and the table (capacity · 16 bytes).
// The ray bounds are the static bounds joined with the touched bricks.
// The overlay grows (one full re-upload) when a frame needs more bricks.
// Test: tests/render/test_guidance_buffers.cpp (identical hits to a world rebuilt
// from scratch with the same cells).
#pragma once

#include "render/buffers/frame_scene.h"
#include "render/raycast_gpu.h"

#include <cstdint>
#include <map>
#include <vector>

namespace icube::render {

struct OverlayStats {
  size_t cells = 0;             // car cells written
  size_t bricks = 0;            // bricks patched (copied from static or new)
  size_t new_bricks = 0;        // of those, not in the static world
  size_t uploaded_bytes = 0;    // this frame
  double build_s = 0.0, upload_s = 0.0;
};

// The car cells grouped by brick (brick_key order, so slots are assigned deterministically);
// cells outside the grid's range are dropped.
std::map<uint64_t, std::vector<const CarCell*>> car_cells_by_brick(const std::vector<CarCell>& cells);
// Paints a brick's car cells into its record `rec` (a copy of the static brick or zeros): class
// car with the cell's instance, except where a car instance is already painted; counts st.cells.
void paint_car_cells(uint32_t* rec, const std::vector<const CarCell*>& cells, OverlayStats& st);

class OverlayWorld {
 public:
  OverlayWorld(gpu::Context& ctx, const world::VoxelGrid& static_world, size_t overlay_capacity = 64);

  // Replaces the previous frame's overlay with `cells` and uploads it.
  OverlayStats set_overlay(const std::vector<CarCell>& cells);
  const RaycastWorld& world() const { return world_; }
  size_t static_bricks() const { return static_count_; }
  size_t static_upload_bytes() const { return static_bytes_; }

 private:
  void allocate(size_t overlay_capacity);  // buffers + table for static + capacity bricks
  uint32_t find_slot(uint64_t key) const;  // slot holding key, or the empty slot where it would go

  gpu::Context& ctx_;
  std::vector<uint32_t> static_records_;   // WORLD_BRICK_UINTS per static brick
  std::vector<uint64_t> static_keys_;      // brick_key per static brick
  world::IjkBounds static_bounds_;
  size_t static_count_ = 0, capacity_ = 0, static_bytes_ = 0;
  std::vector<shader::WorldHashEntry> table_;  // host copy, static entries + current overlay
  std::vector<std::pair<uint32_t, shader::WorldHashEntry>> dirty_;  // slot, static value to restore
  RaycastWorld world_;
};

}  // namespace icube::render

// One persistent GPU world whose static bricks change a slice at a time
// (library icube_viewer_core; residency.h decides which bricks), with the
// dynamic car cells patched in like render::OverlayWorld.
//
// Layout (world_layout.h, the hash format of gpu_world.cpp, unchanged):
// brick_data holds static_capacity static slots followed by overlay_capacity
// overlay slots, allocated once; brick_table has bit_ceil(2 · all slots)
// entries (load <= 0.5), mirrored on the host. Static slots are handed out from
// a free list (lowest first, so a batch lands in few contiguous runs, one upload
// per run); a slot holds its record on the host too, so car patches copy it.
//
// An update between frames, while the GPU does not read the world (the caller
// waits for the frame in flight): remove_static() frees slots (host only),
// add_static() writes new records into free slots (host + GPU; no table entry
// points at a free slot, so the GPU never reads a half-written record), and
// commit() updates the table (rebuilt from the slots in slot order after
// removals, else the new entries inserted; then the current car overlay
// re-patched as set_overlay does), uploads it,
// recomputes the bounds (union of the resident bricks' boxes) and bumps the
// revision (the ray caster rebuilds its occupancy masks once).
// set_overlay(cells): OverlayWorld's rule (a car cell replaces a static voxel
// unless that voxel is a static car's cell; class CAR, the car's instance),
// overlay records + table uploaded. More car bricks than overlay slots: the
// buffer is reallocated with twice the overlay slots (one full re-upload).
// Test: tests/viewer/test_viewer_resident_world.cpp (probes equal to a world built
// from scratch after removals, additions and overlays).
#pragma once

#include "render/buffers/frame_scene.h"
#include "render/buffers/overlay_world.h"
#include "render/raycast_gpu.h"

#include <cstdint>
#include <unordered_map>
#include <utility>
#include <vector>

namespace icube::viewer {

class ResidentWorld {
 public:
  ResidentWorld(gpu::Context& ctx, const glm::dvec3& origin, double voxel_size, size_t static_capacity,
                size_t overlay_capacity = 64);

  // Frees the slots of the resident bricks among `keys` (brick_key); takes effect at commit().
  void remove_static(const std::vector<uint64_t>& keys);
  // Writes n bricks (keys[i], records + i · WORLD_BRICK_UINTS) into free slots; a key already
  // resident is replaced. Throws when the static slots run out.
  void add_static(const uint64_t* keys, const uint32_t* records, size_t n);
  // Table, bounds and revision for the static bricks now resident plus the current overlay.
  void commit();
  // Replaces the car overlay with `cells` and uploads it (OverlayWorld::set_overlay's rule).
  render::OverlayStats set_overlay(const std::vector<render::CarCell>& cells);

  const render::RaycastWorld& world() const { return world_; }
  size_t static_bricks() const { return slot_of_.size(); }
  size_t static_capacity() const { return static_capacity_; }
  bool resident_key(uint64_t key) const { return slot_of_.count(key) != 0; }
  // Bytes uploaded by the last add_static / commit / set_overlay call.
  size_t last_upload_bytes() const { return last_bytes_; }

 private:
  void allocate(size_t overlay_capacity);     // buffers for all slots; uploads the resident records
  void rebuild_static_table();                 // table_ = the static entries only
  render::OverlayStats patch_overlay();        // cells_ into the overlay slots + table entries (host), uploads them
  uint32_t find_slot(uint64_t key) const;      // table slot holding key, or the empty one where it would go

  gpu::Context& ctx_;
  size_t static_capacity_ = 0, overlay_capacity_ = 0;
  std::vector<uint32_t> records_;              // host copy of the static slots' records
  std::vector<uint64_t> key_of_;               // per static slot: its brick key, or kFree
  std::vector<uint32_t> free_;                 // free static slots, sorted descending (pop_back = lowest)
  std::unordered_map<uint64_t, uint32_t> slot_of_;
  std::vector<shader::WorldHashEntry> table_;
  std::vector<std::pair<uint32_t, shader::WorldHashEntry>> dirty_;  // table slot, static value to restore
  std::vector<render::CarCell> cells_;         // the current overlay
  std::vector<uint32_t> added_;                // static slots filled since the last commit
  bool rebuild_ = true;                        // removals (or a new table) since the last commit
  world::IjkBounds static_bounds_;
  size_t last_bytes_ = 0;
  render::RaycastWorld world_;
};

}  // namespace icube::viewer

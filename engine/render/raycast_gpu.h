// GPU host module for the voxel ray caster, shaders/raycast/cast.comp (traversal in
// shaders/raycast/traverse.glsl; params and the per-ray RaycastHit in
// shaders/shared/raycast_params.h). Same rules and outputs as the CPU
// reference engine/render/raycast_cpu.h, in float, relative to a reference
// voxel: the camera's voxel (camera mode) or the first ray's origin voxel (ray
// lists), split on the host in double into int ijk + float offset, so a
// camera 100 km from the grid origin renders the same image as at the origin.
// Traversal is limited to RAYCAST_MAX_REL voxels (±839 km at 0.2 m) around
// the reference voxel and to the world's brick bounds.
// Camera casts add an exact pass for the semantic chords within float rounding
// of eps_sem: in double (shaders/raycast/exact.comp) or, without shaderFloat64,
// in double-float (shaders/raycast/exact_df.comp).
// Tests: tests/render/test_raycast.cpp, test_raycast_index.cpp, test_raycast_df.cpp;
// benchmark: bench/bench_raycast.cpp.
#pragma once

#include "gpu/buffer.h"
#include "gpu/commands.h"
#include "render/camera.h"
#include "render/raycast_cpu.h"
#include "shared/raycast_df_params.h"
#include "shared/raycast_f64_params.h"
#include "shared/raycast_params.h"
#include "world/gpu_world.h"

#include <cstdint>
#include <vector>

namespace icube::render {

// The GPU world plus the brick bounds the kernel clips rays to.
// id != 0 (upload_raycast_world gives each world a new one) lets a RaycasterGpu
// keep the world's occupancy masks between records instead of rebuilding them:
// whoever changes gpu.brick_table, gpu.brick_data or bounds in place afterwards
// must ++revision. id 0 (a world assembled by hand, e.g. OverlayWorld's, which
// patches its buffers every frame): the masks are rebuilt on every record.
struct RaycastWorld {
  world::GpuWorld gpu;
  world::IjkBounds bounds;  // raycast_bounds(grid)
  uint64_t id = 0;
  uint64_t revision = 0;
};

RaycastWorld upload_raycast_world(gpu::Context& ctx, const world::VoxelGrid& grid);
// A new RaycastWorld id (never 0), for worlds assembled by hand that keep revision up to date.
uint64_t new_raycast_world_id();

// Rays uploaded for ray-list mode: 2 vec4 per ray (origin relative to `ref`
// in voxel units, unit direction).
struct GpuRayBatch {
  gpu::Buffer rays;
  uint32_t count = 0;
  glm::ivec3 ref{0};
};

class RaycasterGpu {
 public:
  // skip_empty_bricks = false selects the flat walk (every voxel of every brick; for benchmarks).
  explicit RaycasterGpu(gpu::Context& ctx, bool skip_empty_bricks = true);

  // Occupancy index (on by default with skip_empty_bricks; layout in
  // shared/raycast_params.h): a (block, 32 x 32 column height) pair per 32³ super
  // brick of the bounds, per occupied super brick a block of 64 (brick record + 4³
  // octant bits, 8 x 8 column height) pairs, and a copy of every record's mask,
  // built from the brick table (raycast/occupancy.comp: a fill and three passes);
  // the kernel skips column tops, empty super bricks, bricks and octants and finds
  // a voxel's cell in three fetches without hashing. A record
  // rebuilds it unless the last build was for the same world (RaycastWorld id != 0,
  // same revision and layout); a recorded command list must then be submitted
  // before the next record relies on it. Off: empty bricks are found by hash
  // lookups (the same results; for benchmarks). Worlds whose index would pass
  // kMaxOccupancyWords words or one storage binding (the build writes it through one) run
  // without (the hash-table pipeline). The index, the hash table and the brick words are read
  // as texel buffers. Casts whose hits (48 bytes a ray) or rays exceed one storage binding run
  // in windows of rays (whole tile rows in camera mode; the same results).
  static constexpr uint64_t kMaxOccupancyWords = uint64_t{1} << 25;
  void set_occupancy(bool on) { occupancy_ = on; }
  // Number of occupancy builds recorded so far (for tests and benchmarks).
  uint64_t occupancy_builds() const { return occ_builds_; }
  bool occupancy() const { return occupancy_; }
  // Camera mode: each subgroup covers a 2-D pixel sub-tile (tile_width() x subgroup / tile_width(),
  // e.g. 4x2 on lavapipe, 8x4 at subgroup 32) and a workgroup of 64 invocations an 8x8 tile of them,
  // instead of runs of pixels in a row. Same results.
  void set_tiled(bool on) { tiled_ = on; }
  bool tiled() const { return tiled_; }
  // Camera casts with near-threshold semantic chords decided as the double CPU reference does:
  // the float pass lists the rays whose decision met a chord within float rounding of eps_sem
  // and a second pass casts only those again, with those chords in double
  // (shaders/raycast/exact.comp) where the device has shaderFloat64, else in double-float
  // (shaders/raycast/exact_df.comp: fp32 pairs, ~48 bits); on by default; off: the float
  // kernel alone.
  void set_exact(bool on) { exact_ = on; }
  bool exact() const { return exact_; }
  // The float-only exact pass (raycast/exact_df.comp) even where the device has shaderFloat64
  // (the route of devices without it; for tests and benchmarks on lavapipe).
  void set_exact_float_only(bool on) { force_df_ = on; }
  // Whether the exact pass (when on) decides in double-float.
  bool exact_float_only() const;
  uint32_t tile_width() const { return tile_w_; }
  // Ray-list casts flag (RAYCAST_FLAG_NEAR in RaycastHit.flags) every ray whose walk, semantic chord or
  // depth run came within float rounding of a decision that a double walk of the same ray could take
  // the other way: another axis's voxel plane within ~7 ulps of the position where the walk leaves a
  // cell; a start point that near planes with an occupied voxel among the 2^k around it (or on a plane
  // it moves along); a chord within rounding of eps_sem; a run within rounding of eps_depth
  // (raycast/traverse.glsl, raycast_tie_eps). A caller that re-casts the flagged rays in double gets
  // the double walk's results for every ray (engine/nn/gsm/gsm_rays_gpu.h; tested there, with rays
  // through voxel edges and corners the float walk alone decides otherwise). Off by default (a
  // pipeline of its own); camera casts ignore it.
  void set_mark_ties(bool on) { mark_ties_ = on; }
  bool mark_ties() const { return mark_ties_; }

  // Push constants for a camera (camera mode) / for a ray batch (ray-list mode).
  shader::RaycastParams camera_params(const RaycastWorld& w, const Camera& cam, const RaycastOptions& opts) const;
  shader::RaycastParams ray_params(const RaycastWorld& w, const GpuRayBatch& rays, const RaycastOptions& opts) const;

  // Directions are normalised in double before rounding to float; normalise = false uploads them as
  // given (rounded to float), for callers whose float directions are the reference's bit for bit.
  GpuRayBatch upload_rays(const RaycastWorld& w, const std::vector<Ray>& rays, bool normalise = true);

  // Record one dispatch writing W·H (or rays.count) RaycastHits to `hits`
  // (>= 48 bytes per ray). The caller orders earlier uses of `hits` before
  // this and puts a barrier before reading it on the GPU (submit_and_wait's
  // final barrier suffices for the host).
  void record_camera(gpu::CommandList& cmd, const RaycastWorld& w, const Camera& cam, const RaycastOptions& opts,
                     const gpu::Buffer& hits);
  void record_rays(gpu::CommandList& cmd, const RaycastWorld& w, const GpuRayBatch& rays, const RaycastOptions& opts,
                   const gpu::Buffer& hits);

  // Upload (rays), run, download.
  std::vector<shader::RaycastHit> cast_camera(const RaycastWorld& w, const Camera& cam, const RaycastOptions& opts);
  std::vector<shader::RaycastHit> cast_rays(const RaycastWorld& w, const std::vector<Ray>& rays,
                                            const RaycastOptions& opts);

  // The world as the kernels read it: the hash table as R32G32B32A32_UINT and the brick words as
  // R32_UINT texels (bounded by maxTexelBufferElements, not by one storage binding).
  static gpu::BufferBinding table_texels(const RaycastWorld& w);
  static gpu::BufferBinding brick_texels(const RaycastWorld& w);

 private:
  void record(gpu::CommandList& cmd, const RaycastWorld& w, const shader::RaycastParams& params,
              const gpu::BufferBinding& rays, const gpu::Buffer& hits, const shader::RaycastCameraF64* cam64 = nullptr);
  // The ray-casting pipeline: rows or tiles, occupancy index or hash table, float pass or the
  // exact pass (raycast/exact, needs shaderFloat64, or raycast/exact_df: exact_float_only()).
  gpu::Program& cast_program(bool tiled, bool occupancy, bool exact, bool mark_ties = false) const;
  gpu::Context& ctx_;
  static constexpr uint64_t kExactPassThreads = 4096;  // the exact pass's grid
  gpu::Program& occupancy_program_;
  uint32_t tile_w_ = 1;   // subgroup sub-tile width
  uint32_t wg_w_ = 1;     // workgroup tile width
  uint32_t wg_lanes_ = 1; // invocations per workgroup
  bool tiled_ = true;
  bool skip_empty_ = true;
  bool occupancy_ = true;
  gpu::Buffer occ_;         // occupancy index, grown on demand (the outgrown one retired: Context::retire)
  // What occ_ holds: the world (id, revision) and layout of the last build, when cacheable.
  bool occ_cached_ = false;
  uint64_t occ_builds_ = 0;
  uint64_t occ_id_ = 0, occ_revision_ = 0;
  shader::RaycastOccupancyParams occ_params_{};
  gpu::Buffer near_;   // the float pass's list of near-threshold rays (count, indices)
  gpu::Buffer exact_camera_;  // the camera of the last exact camera record (RaycastCameraF64 or RaycastCameraDf)
  bool exact_ = true;
  bool force_df_ = false;
  bool mark_ties_ = false;
};

// The camera of the exact pass in double (RaycastCameraF64): its rotation, intrinsics, offset
// from its voxel's corner in a grid at grid_origin with voxel_size, eps_sem and t_max.
shader::RaycastCameraF64 camera_f64(const Camera& cam, const glm::dvec3& grid_origin, double voxel_size,
                                    const RaycastOptions& opts);
// The camera in double-float pairs (RaycastCameraDf) of a double camera (hi = float(d),
// lo = float(d - hi); t_max clamped to FLT_MAX).
shader::RaycastCameraDf camera_df(const shader::RaycastCameraF64& c);

// Test hook for the double-float primitives of shaders/common/df.glsl and the ray caster's df
// chord: dispatches shaders/raycast/df_check.comp with params.op (RAYCAST_DF_*; n is set here)
// on (a.hi, a.lo, b.hi, b.lo) values (RAYCAST_DF_CHORD: voxel and pixel bits, `cam`) and
// returns the (hi, lo) results. Test: tests/render/test_raycast_df.cpp.
std::vector<glm::vec2> df_check_gpu(gpu::Context& ctx, const shader::RaycastDfCheckParams& params,
                                    const std::vector<glm::vec4>& values, const shader::RaycastCameraDf& cam = {});

}  // namespace icube::render

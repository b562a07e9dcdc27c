// LiDAR on Gaussians, GPU host module (shaders/splat/lidar_bin.comp,
// splat/lidar_duplicate.comp, splat/lidar_cast.comp, the tile-range kernel
// splat/ranges.comp shared with the rasterizer, and the foundation PrefixScan and
// 64-bit RadixSort of kernels/). Same rays, maths and outputs as the CPU
// reference lidar_gaussians_cpu.h, in float.
//
// Acceleration: the range image (beams x columns, lidar_model.h) is cut into
// tiles of 4 rings x 16 columns (64 rays, one cast workgroup). Per sweep:
//   1. bin: each Gaussian's cut sphere (radius r_cut, the exact reach of the
//      1/255 test) projected to an azimuth/elevation rectangle of tiles in
//      the sensor frame (conservative float margins; the ±180° azimuth wrap
//      as a run of tile columns modulo the tile count; a sphere containing
//      the sensor touches every tile) -> inclusive PrefixScan of tiles
//      touched -> the total to the host (one CPU sync);
//   2. duplicate (tile << 32 | bits of max(0, |μ−o| − r_cut)) -> RadixSort of
//      the low 32 + bits(#tiles) bits -> tile ranges -> cast: per ray, walk
//      the tile's list in bound order, keep up to K = 8 pending contributors
//      sorted by (t*, index) in registers and composite each once the next
//      bound passes it; more than K pending: the largest waits for another
//      pass over the list (the OVERFLOW flag), so the order is always the
//      reference's; after 64 passes the rest is dropped (TRUNCATED).
// Design for lavapipe (8-wide subgroups, slow shared memory and barriers):
// no shared memory, subgroups share a tile list and its loads (coherent
// reads, like splat_blend); on real GPUs the same scheme is the 3DGS tile
// rasterizer's, with 64-ray tiles as workgroups.
// Precision: positions are uploaded once relative to a scene origin (whole
// metres near the bounding-box centre, double on the host), the sensor origin
// is split against it per sweep, so a scene 100 km from the origin casts the
// same; whitening matrices come from the double computation of the reference.
// Limits: the Gaussian records are bound as up to SPLAT_LIDAR_WINDOWS (4)
// storage windows (lavapipe 128 MiB each: 8.3 M Gaussians; the per-Gaussian
// rectangles, 16 bytes, reach the same bound), the tile instances one binding
// (lavapipe: 16 M); larger sweeps fail with a clear message.
// Tests: tests/splat/test_lidar_gaussians.cpp; benchmark: bench/bench_lidar_gaussians.cpp.
#pragma once

#include "gpu/buffer.h"
#include "gpu/commands.h"
#include "kernels/prefix_scan.h"
#include "kernels/radix_sort.h"
#include "splat/lidar_gaussians_cpu.h"

#include <memory>

namespace icube::splat {

struct GpuLidarGaussians {
  gpu::Buffer gaussians;  // SplatLidarGaussian per Gaussian
  uint32_t count = 0;
  glm::dvec3 origin{0.0};
  std::vector<gpu::ElementWindow> windows;  // of records, at most SPLAT_LIDAR_WINDOWS
};

// The records the GPU gets (positions relative to `origin`; r_cut with the binning margin).
std::vector<shader::SplatLidarGaussian> lidar_gaussian_rows(const GaussianCloud& cloud,
                                                            const std::vector<float>& intensity,
                                                            const glm::dvec3& origin);

struct LidarGaussianTimings {
  double bin_ms = 0;   // bin + scan (GPU timestamps; NaN when unsupported)
  double sort_ms = 0;  // duplicate + radix sort + ranges
  double cast_ms = 0;
  double wall_ms = 0;  // both submissions + the hit download
  uint64_t instances = 0;
};

// The binned lists of the last sweep, for tests (stage by stage): splat_lidar_bin +
// splat_lidar_duplicate + radix sort give `keys` (tile << 32 | float bits of the
// Gaussian's lower bound of t*) and `values` (Gaussian index), sorted; splat_ranges
// gives `ranges` (2 per tile: [start, end) into them). Tile id = ty · tiles_x + tx,
// tile (tx, ty) = columns 16·tx .. 16·tx + 15 of rings 4·ty .. 4·ty + 3.
struct LidarGaussianDebug {
  std::vector<uint64_t> keys;
  std::vector<uint32_t> values;
  std::vector<uint32_t> ranges;
};

class LidarGaussiansGpu {
 public:
  LidarGaussiansGpu(gpu::Context& ctx, const render::LidarModel& model);  // validates the model
  ~LidarGaussiansGpu();

  // `intensity`: one value per Gaussian (lidar_gaussian_intensity for the default). `origin`: the
  // whole metres the positions are stored relative to (default: the centre of the set's bounds); a
  // subset of a larger set (lidar_range_subset) passes the whole set's lidar_origin, so its sweeps
  // are the whole set's bit for bit.
  GpuLidarGaussians upload(const GaussianCloud& cloud, const std::vector<float>& intensity,
                           const glm::dvec3* origin = nullptr);
  // The most Gaussians one upload takes on this device (SPLAT_LIDAR_WINDOWS storage windows of records,
  // one binding of tile rects); larger sets are cast per sweep through lidar_range_subset.
  uint64_t max_gaussians() const;
  // The origin upload() uses for `cloud` by default.
  static glm::dvec3 lidar_origin(const GaussianCloud& cloud);
  // The Gaussians of `cloud` a sweep from `sensor` can reach (lidar_range_subset), uploaded at the
  // whole cloud's origin: the whole cloud's sweep bit for bit, for sets over one upload.
  GpuLidarGaussians upload_within_reach(const GaussianCloud& cloud, const glm::dvec3& sensor);
  // One sweep from `sensor_to_world`; hits in ray order. `download` = false leaves them on the GPU (benchmarks).
  std::vector<shader::SplatLidarHit> cast(const GpuLidarGaussians& g, const glm::dmat4& sensor_to_world,
                                          LidarGaussianTimings* timings = nullptr, bool download = true,
                                          LidarGaussianDebug* debug = nullptr);
  render::LidarScan scan(const GpuLidarGaussians& g, const glm::dmat4& sensor_to_world,
                         const LidarGaussianOptions& opts, LidarGaussianTimings* timings = nullptr);

  const render::LidarModel& model() const { return model_; }
  const std::vector<glm::dvec3>& directions() const { return dirs_; }
  uint32_t tiles_x() const { return tiles_x_; }
  uint32_t tiles_y() const { return tiles_y_; }
  // Tile rows one cast dispatch covers: all of them unless the sweep's hits exceed one storage binding,
  // then batches of whole tile rows (0: one tile row alone exceeds a binding, refused by the constructor).
  uint32_t cast_tile_rows() const;

 private:
  struct Frame;
  gpu::Context& ctx_;
  render::LidarModel model_;
  std::vector<glm::dvec3> dirs_;
  uint32_t tiles_x_ = 0, tiles_y_ = 0;
  gpu::Program& bin_;
  gpu::Program& duplicate_;
  gpu::Program& ranges_;
  gpu::Program& cast_;
  gpu::Buffer dirs_gpu_, elev_gpu_, hits_;
  std::unique_ptr<Frame> f_;
};

}  // namespace icube::splat

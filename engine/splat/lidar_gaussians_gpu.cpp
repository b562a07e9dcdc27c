// LiDAR on Gaussians, GPU host module; see lidar_gaussians_gpu.h.
#include "splat/lidar_gaussians_gpu.h"

#include "splat/tile_radix_binning_gpu.h"

#include <algorithm>
#include <array>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstring>
#include <numbers>
#include <stdexcept>

namespace icube::splat {

namespace {
constexpr uint32_t kLocal = 64;  // = SPLAT_LIDAR_TILE_RAYS; the other kernels take any multiple of the subgroup size
static_assert(SPLAT_LIDAR_TILE_ROWS * SPLAT_LIDAR_TILE_COLS == SPLAT_LIDAR_TILE_RAYS);

gpu::SpecConstants local_size() { return gpu::SpecConstants{}.set(0, kLocal /* local_size_x */); }

const render::LidarModel& validated(const render::LidarModel& m) {
  render::validate_lidar(m);
  return m;
}
}  // namespace

std::vector<shader::SplatLidarGaussian> lidar_gaussian_rows(const GaussianCloud& cloud,
                                                            const std::vector<float>& intensity,
                                                            const glm::dvec3& origin) {
  if (intensity.size() != cloud.size()) throw std::invalid_argument("lidar gaussians: one intensity per Gaussian");
  std::vector<shader::SplatLidarGaussian> rows(cloud.size());
  for (size_t i = 0; i < cloud.size(); ++i) {
    const LidarGaussian g =
        lidar_gaussian(cloud.positions[i], cloud.scales[i], cloud.rotations[i], cloud.opacities[i], intensity[i]);
    const glm::dvec3 p = g.mean - origin;
    auto w = [&](int r, int c) { return static_cast<float>(g.W[c][r]); };
    // Binning margin: float rounding of the cast's 1/255 test and of the distances.
    const float r_cut = g.r_cut > 0.0 ? static_cast<float>(g.r_cut * 1.001 + 1e-4) : 0.0f;
    rows[i] = shader::SplatLidarGaussian{static_cast<float>(p.x),
                                         static_cast<float>(p.y),
                                         static_cast<float>(p.z),
                                         static_cast<float>(g.opacity),
                                         w(0, 0),
                                         w(0, 1),
                                         w(0, 2),
                                         static_cast<float>(g.intensity),
                                         w(1, 0),
                                         w(1, 1),
                                         w(1, 2),
                                         r_cut,
                                         w(2, 0),
                                         w(2, 1),
                                         w(2, 2),
                                         0.0f};
  }
  return rows;
}

struct LidarGaussiansGpu::Frame {
  explicit Frame(gpu::Context& ctx) : binning(ctx, kernels::KeyWidth::Bits64, "lidar-gs") {}
  gpu::Buffer rects, bound, ranges, total;
  TileRadixBinning binning;  // touched counts -> offsets -> total; keys/values -> sort -> ranges
  std::unique_ptr<gpu::GpuTimer> t1, t2;
};

LidarGaussiansGpu::LidarGaussiansGpu(gpu::Context& ctx, const render::LidarModel& model)
    : ctx_(ctx),
      model_(validated(model)),
      dirs_(render::lidar_directions(model_)),
      tiles_x_(static_cast<uint32_t>(gpu::div_up(model_.columns, SPLAT_LIDAR_TILE_COLS))),
      tiles_y_(static_cast<uint32_t>(gpu::div_up(model_.beams(), SPLAT_LIDAR_TILE_ROWS))),
      bin_(ctx.program("splat/lidar_bin", local_size())),
      duplicate_(ctx.program("splat/lidar_duplicate", local_size())),
      ranges_(ctx.program("splat/ranges", local_size())),
      cast_(ctx.program("splat/lidar_cast", local_size())),
      f_(std::make_unique<Frame>(ctx)) {
  // The cast binds the hits (and directions) of whole tile rows per dispatch: one tile row must fit a binding.
  if (cast_tile_rows() == 0)
    throw std::invalid_argument("lidar gaussians: one row of range-image tiles (" +
                                std::to_string(SPLAT_LIDAR_TILE_ROWS) + " beams x " + std::to_string(model_.columns) +
                                " columns) exceeds one storage binding of hits; use fewer columns");
  std::vector<glm::vec4> d(dirs_.size());
  for (size_t i = 0; i < d.size(); ++i) d[i] = glm::vec4(glm::vec3(dirs_[i]), 0.0f);
  dirs_gpu_ = gpu::upload_vector(ctx_, d, "lidar-gs-dirs");
  std::vector<float> e(model_.beams());
  for (size_t r = 0; r < e.size(); ++r) e[r] = static_cast<float>(model_.elevations_deg[r] * std::numbers::pi / 180.0);
  elev_gpu_ = gpu::upload_vector(ctx_, e, "lidar-gs-elevations");
  hits_ = gpu::Buffer(ctx_, model_.rays() * sizeof(shader::SplatLidarHit), gpu::MemoryUsage::DeviceLocal, "lidar-gs-hits");
  f_->t1 = std::make_unique<gpu::GpuTimer>(ctx, 2);
  f_->t2 = std::make_unique<gpu::GpuTimer>(ctx, 4);
  f_->total = gpu::Buffer(ctx, 16, gpu::MemoryUsage::Readback, "lidar-gs-total");
  f_->ranges = gpu::Buffer(ctx, uint64_t{tiles_x_} * tiles_y_ * 8, gpu::MemoryUsage::DeviceLocal, "lidar-gs-ranges");
}

LidarGaussiansGpu::~LidarGaussiansGpu() = default;

uint32_t LidarGaussiansGpu::cast_tile_rows() const {
  // Less one offset alignment: a batch's hits are bound from the aligned offset at or below its first ray.
  const uint64_t align = std::max<uint64_t>(16, ctx_.info().min_storage_buffer_offset_alignment);
  const uint64_t range = ctx_.info().max_storage_buffer_range;
  const uint64_t rays = range > align ? (range - align) / sizeof(shader::SplatLidarHit) : 0;
  return static_cast<uint32_t>(std::min<uint64_t>(rays / (uint64_t{SPLAT_LIDAR_TILE_ROWS} * model_.columns), tiles_y_));
}

uint64_t LidarGaussiansGpu::max_gaussians() const {
  // storage_windows' window length for the records, times the windows the kernels bind.
  const gpu::DeviceInfo& info = ctx_.info();
  const uint64_t row = sizeof(shader::SplatLidarGaussian);
  const uint64_t unit = std::max<uint64_t>(1, info.min_storage_buffer_offset_alignment / row);
  const uint64_t per_window = info.max_storage_buffer_range / row / unit * unit;
  return std::min<uint64_t>({SPLAT_LIDAR_WINDOWS * per_window, info.max_storage_buffer_range / 16, UINT32_MAX / 8});
}

glm::dvec3 LidarGaussiansGpu::lidar_origin(const GaussianCloud& cloud) {
  if (cloud.positions.empty()) return glm::dvec3(0.0);
  glm::dvec3 lo = cloud.positions[0], hi = lo;
  for (const auto& p : cloud.positions) {
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  }
  return glm::floor(0.5 * (lo + hi));  // whole metres: exact in float
}

GpuLidarGaussians LidarGaussiansGpu::upload_within_reach(const GaussianCloud& cloud, const glm::dvec3& sensor) {
  const glm::dvec3 origin = lidar_origin(cloud);
  const GaussianCloud near = lidar_range_subset(cloud, sensor, model_.max_range);
  return upload(near, lidar_gaussian_intensity(near), &origin);
}

GpuLidarGaussians LidarGaussiansGpu::upload(const GaussianCloud& cloud, const std::vector<float>& intensity,
                                            const glm::dvec3* origin) {
  cloud.validate();
  if (cloud.size() > UINT32_MAX / 8) throw std::invalid_argument("lidar gaussians: too many Gaussians");
  GpuLidarGaussians g;
  g.windows = gpu::storage_windows(ctx_.info(), cloud.size(), sizeof(shader::SplatLidarGaussian));
  const uint64_t rect_bytes = cloud.size() * 16;  // the per-Gaussian tile rectangles of a sweep
  if (g.windows.size() > SPLAT_LIDAR_WINDOWS || rect_bytes > ctx_.info().max_storage_buffer_range)
    throw std::invalid_argument(
        "lidar gaussians: " + std::to_string(cloud.size()) + " Gaussians exceed this device's limit of " +
        std::to_string(max_gaussians()) +
        " (" + std::to_string(SPLAT_LIDAR_WINDOWS) + " storage windows); cull the set to the sensor's range first");
  g.count = static_cast<uint32_t>(cloud.size());
  g.origin = origin ? glm::floor(*origin) : lidar_origin(cloud);
  g.gaussians = gpu::upload_vector(ctx_, lidar_gaussian_rows(cloud, intensity, g.origin), "lidar-gs-gaussians");
  return g;
}

std::vector<shader::SplatLidarHit> LidarGaussiansGpu::cast(const GpuLidarGaussians& g, const glm::dmat4& s2w,
                                                           LidarGaussianTimings* timings, bool download,
                                                           LidarGaussianDebug* debug) {
  const auto t0 = std::chrono::steady_clock::now();
  Frame& f = *f_;
  const uint64_t n = g.count;
  const uint32_t tiles = tiles_x_ * tiles_y_;
  const glm::dmat3 R(s2w);
  const glm::dvec3 o = glm::dvec3(s2w[3]) - g.origin;
  shader::SplatLidarParams p{};
  p.n = g.count;
  p.beams = model_.beams();
  p.columns = model_.columns;
  p.tiles_x = tiles_x_;
  p.tiles_y = tiles_y_;
  p.min_range = static_cast<float>(model_.min_range);
  p.max_range = static_cast<float>(model_.max_range);
  const double two_pi = 2.0 * std::numbers::pi;
  double start = std::fmod(model_.start_azimuth_deg * std::numbers::pi / 180.0, two_pi);
  if (start < 0.0) start += two_pi;
  p.start_azimuth = static_cast<float>(start);
  float* s = &p.s00;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) s[3 * r + c] = static_cast<float>(R[c][r]);  // row-major
  p.ox = static_cast<float>(o.x);
  p.oy = static_cast<float>(o.y);
  p.oz = static_cast<float>(o.z);
  p.window_n = g.windows.empty() ? 1u : static_cast<uint32_t>(g.windows[0].count);
  // The record windows (null bindings past the last).
  std::array<gpu::BufferBinding, SPLAT_LIDAR_WINDOWS> gw;
  for (size_t w = 0; w < gw.size(); ++w)
    gw[w] = w < g.windows.size()
                ? g.gaussians.binding(g.windows[w].first * sizeof(shader::SplatLidarGaussian),
                                      g.windows[w].count * sizeof(shader::SplatLidarGaussian))
                : gpu::null_binding();

  gpu::ensure_capacity(ctx_, f.rects, n * 16, "lidar-gs-rects");
  gpu::ensure_capacity(ctx_, f.bound, n * 4, "lidar-gs-bound");
  f.binning.reserve_items(n);
  const gpu::Buffer& touched = f.binning.counts();
  const gpu::Buffer& offsets = f.binning.offsets();

  // Submission 1: bin, scan of the tile counts, the total to the host.
  uint32_t total = 0;
  double bin_ms = 0.0;
  if (n > 0) {
    ctx_.submit_and_wait([&](gpu::CommandList& cmd) {
      f.t1->reset(cmd);
      const int ti = f.t1->begin(cmd, "bin");
      cmd.dispatch(bin_, {n}, p,
                   {gw[0], gw[1], gw[2], gw[3], elev_gpu_.binding(0, uint64_t{model_.beams()} * 4),
                    f.rects.binding(0, n * 16),
                    touched.binding(0, n * 4), f.bound.binding(0, n * 4)});
      cmd.barrier(gpu::deps::kComputeToCompute);  // the scan reads touched[]
      f.binning.record_scan(cmd, n, f.total.binding(0, 4));
      f.t1->end(cmd, ti);
    });
    std::memcpy(&total, f.total.mapped(), 4);
    bin_ms = f.t1->milliseconds(0);
  }

  // Submission 2: keys, sort, ranges, cast.
  const uint64_t inst = total;
  f.binning.reserve_instances(inst);
  const gpu::Buffer& keys = f.binning.keys();
  const gpu::Buffer& values = f.binning.values();
  const uint32_t key_bits = 32 + std::max<uint32_t>(1, static_cast<uint32_t>(std::bit_width(tiles - 1u)));
  const uint64_t rays = model_.rays();
  ctx_.submit_and_wait([&](gpu::CommandList& cmd) {
    f.t2->reset(cmd);
    const int ts = f.t2->begin(cmd, "sort");
    if (inst > 0) {
      cmd.dispatch(duplicate_, {n}, p,
                   {f.rects.binding(0, n * 16), touched.binding(0, n * 4), offsets.binding(0, n * 4),
                    f.bound.binding(0, n * 4), keys.binding(0, inst * 8), values.binding(0, inst * 4)});
      cmd.barrier(gpu::deps::kComputeToCompute);  // the sort reads the keys and values
    }
    f.binning.record_sort_ranges(cmd, inst, key_bits, ranges_, f.ranges, tiles);
    f.t2->end(cmd, ts);
    cmd.barrier(gpu::deps::kComputeToCompute);  // the cast reads the ranges
    const int tc = f.t2->begin(cmd, "cast");
    // Batches of whole tile rows (one unless the sweep's hits exceed a binding); they write disjoint rays.
    const uint32_t batch_rows = cast_tile_rows();
    for (uint32_t row0 = 0; row0 < tiles_y_; row0 += batch_rows) {
      const uint32_t rows_here = std::min(batch_rows, tiles_y_ - row0);
      const uint64_t first = uint64_t{row0} * SPLAT_LIDAR_TILE_ROWS * model_.columns;
      const uint64_t last = std::min<uint64_t>(rays, uint64_t{row0 + rows_here} * SPLAT_LIDAR_TILE_ROWS * model_.columns);
      const auto window = [&](const gpu::Buffer& buf, uint64_t stride, uint32_t& base) {
        const uint64_t align = std::max<uint64_t>(stride, ctx_.info().min_storage_buffer_offset_alignment);
        const uint64_t bound_from = first * stride / align * align;
        base = static_cast<uint32_t>(bound_from / stride);
        return buf.binding(bound_from, last * stride - bound_from);
      };
      p.tile_row_base = row0;
      const gpu::BufferBinding db = window(dirs_gpu_, 16, p.dirs_base);
      const gpu::BufferBinding hb = window(hits_, sizeof(shader::SplatLidarHit), p.hits_base);
      cmd.dispatch(cast_, {uint64_t{rows_here} * tiles_x_ * SPLAT_LIDAR_TILE_RAYS}, p,
                   {f.ranges.binding(0, uint64_t{tiles} * 8), keys.binding(0, std::max<uint64_t>(inst, 1) * 8),
                    values.binding(0, std::max<uint64_t>(inst, 1) * 4), gw[0], gw[1], gw[2], gw[3], db, hb});
    }
    f.t2->end(cmd, tc);
  });
  std::vector<shader::SplatLidarHit> hits;
  if (download) hits = gpu::download_vector<shader::SplatLidarHit>(ctx_, hits_, rays);
  if (debug) {
    debug->keys = inst ? gpu::download_vector<uint64_t>(ctx_, keys, inst) : std::vector<uint64_t>{};
    debug->values = inst ? gpu::download_vector<uint32_t>(ctx_, values, inst) : std::vector<uint32_t>{};
    debug->ranges = gpu::download_vector<uint32_t>(ctx_, f.ranges, uint64_t{tiles} * 2);
  }
  if (timings) {
    timings->bin_ms = bin_ms;
    timings->sort_ms = f.t2->milliseconds(0);
    timings->cast_ms = f.t2->milliseconds(1);
    timings->instances = inst;
    timings->wall_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  }
  return hits;
}

render::LidarScan LidarGaussiansGpu::scan(const GpuLidarGaussians& g, const glm::dmat4& s2w,
                                          const LidarGaussianOptions& opts, LidarGaussianTimings* timings) {
  return lidar_scan_from_gaussian_hits(model_, dirs_, s2w, cast(g, s2w, timings), opts);
}

}  // namespace icube::splat

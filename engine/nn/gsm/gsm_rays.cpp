// The GSM's pixel rays against its input voxel grid; see gsm_rays.h.
#include "nn/gsm/gsm_rays.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <exception>
#include <limits>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace icube::nn {

namespace {

constexpr int64_t kKeyBias = int64_t{1} << 20;  // coordinates in (-2^20, 2^20)

uint64_t key_of(int64_t i, int64_t j, int64_t k) {
  return (static_cast<uint64_t>(i + kKeyBias) << 42) | (static_cast<uint64_t>(j + kKeyBias) << 21) |
         static_cast<uint64_t>(k + kKeyBias);
}

bool key_range_ok(const Ijk& v) {
  for (int a = 0; a < 3; ++a)
    if (v[a] <= -kKeyBias || v[a] >= kKeyBias - 2) return false;
  return true;
}

}  // namespace

SparseGrid gsm_input_grid(const GsmInputs& in, int64_t b) {
  if (b < 0 || b >= static_cast<int64_t>(in.voxel_ijk.size()))
    throw std::invalid_argument("gsm input grid: batch element " + std::to_string(b) + " of " +
                                std::to_string(in.voxel_ijk.size()));
  SparseGrid g;
  g.ijk = in.voxel_ijk[static_cast<size_t>(b)];
  g.voxel_size = {kGsmVoxelSize, kGsmVoxelSize, kGsmVoxelSize};
  g.origin = {kGsmVoxelOrigin, kGsmVoxelOrigin, kGsmVoxelOrigin};
  return g;
}

std::array<float, 3> gsm_pixel_ray_direction(const std::array<float, 16>& pose, const std::array<float, 6>& intrinsics,
                                             int64_t u, int64_t v) {
  const float fx = intrinsics[0], fy = intrinsics[1], cx = intrinsics[2], cy = intrinsics[3];
  const float local[4] = {(static_cast<float>(u) - cx) / fx, (static_cast<float>(v) - cy) / fy, 1.0f, 1.0f};
  std::array<float, 3> d{};
  for (int i = 0; i < 3; ++i) {
    float p = 0.0f;
    for (int j = 0; j < 4; ++j) p += pose[static_cast<size_t>(4 * i + j)] * local[j];
    d[static_cast<size_t>(i)] = p - pose[static_cast<size_t>(4 * i + 3)];
  }
  const float norm = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
  for (float& c : d) c /= norm;
  return d;
}

double VoxelRayWalk::first_segment_start(double min_length) const {
  for (const auto& s : segments)
    if (!(s[1] - s[0] < min_length)) return s[0];
  return -1.0;
}

VoxelRayGrid::VoxelRayGrid(const SparseGrid& grid) : voxel_size_(grid.voxel_size), origin_(grid.origin) {
  if (grid.ijk.empty()) throw std::invalid_argument("voxel ray grid: no voxels");
  for (int a = 0; a < 3; ++a)
    if (!(voxel_size_[static_cast<size_t>(a)] > 0.0)) throw std::invalid_argument("voxel ray grid: voxel size <= 0");
  lo_ = {grid.ijk[0][0], grid.ijk[0][1], grid.ijk[0][2]};
  hi_ = lo_;
  rows_.reserve(grid.ijk.size() * 2);
  for (size_t r = 0; r < grid.ijk.size(); ++r) {
    const Ijk& v = grid.ijk[r];
    if (!key_range_ok(v)) throw std::invalid_argument("voxel ray grid: coordinate out of range");
    for (int a = 0; a < 3; ++a) {
      lo_[static_cast<size_t>(a)] = std::min<int64_t>(lo_[static_cast<size_t>(a)], v[static_cast<size_t>(a)]);
      hi_[static_cast<size_t>(a)] = std::max<int64_t>(hi_[static_cast<size_t>(a)], v[static_cast<size_t>(a)]);
    }
    if (!rows_.emplace(key_of(v[0], v[1], v[2]), static_cast<int32_t>(r)).second)
      throw std::invalid_argument("voxel ray grid: voxel listed twice");
  }
}

int32_t VoxelRayGrid::row_of(int64_t i, int64_t j, int64_t k) const {
  if (i < lo_[0] || i > hi_[0] || j < lo_[1] || j > hi_[1] || k < lo_[2] || k > hi_[2]) return -1;
  const auto it = rows_.find(key_of(i, j, k));
  return it == rows_.end() ? -1 : it->second;
}

VoxelRayWalk VoxelRayGrid::march(const std::array<double, 3>& origin, const std::array<double, 3>& direction) const {
  VoxelRayWalk walk;
  constexpr double kInf = std::numeric_limits<double>::infinity();
  // The ray in voxel coordinates, where voxel ijk is [ijk, ijk + 1); t is unchanged.
  std::array<double, 3> o{}, d{};
  for (size_t a = 0; a < 3; ++a) {
    o[a] = (origin[a] - origin_[a]) / voxel_size_[a] + 0.5;
    d[a] = direction[a] / voxel_size_[a];
  }
  // Clip to the voxels' bounding box and t >= 0.
  double t0 = 0.0, t1 = kInf;
  for (size_t a = 0; a < 3; ++a) {
    const double lo = static_cast<double>(lo_[a]), hi = static_cast<double>(hi_[a] + 1);
    if (d[a] == 0.0) {
      if (o[a] < lo || o[a] > hi) return walk;
      continue;
    }
    double ta = (lo - o[a]) / d[a], tb = (hi - o[a]) / d[a];
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
  }
  if (t0 > t1) return walk;

  // DDA from the voxel holding the clipped start.
  std::array<int64_t, 3> voxel{}, step{};
  std::array<double, 3> next{};
  for (size_t a = 0; a < 3; ++a) {
    voxel[a] = static_cast<int64_t>(std::floor(o[a] + t0 * d[a]));
    step[a] = d[a] > 0.0 ? 1 : (d[a] < 0.0 ? -1 : 0);
  }
  auto crossing = [&](size_t a) {
    if (step[a] == 0) return kInf;
    const double face = static_cast<double>(voxel[a] + (step[a] > 0 ? 1 : 0));
    return (face - o[a]) / d[a];
  };
  for (size_t a = 0; a < 3; ++a) next[a] = crossing(a);

  double t = t0;
  bool in_run = false;
  double run_start = 0.0;
  while (true) {
    const int32_t row = row_of(voxel[0], voxel[1], voxel[2]);
    if (row >= 0) {
      if (walk.first_voxel < 0) walk.first_voxel = row;
      if (!in_run) {
        in_run = true;
        run_start = t;
      }
    } else if (in_run) {
      walk.segments.push_back({run_start, t});
      in_run = false;
    }
    size_t axis = 0;
    for (size_t a = 1; a < 3; ++a)
      if (next[a] < next[axis]) axis = a;
    t = std::max(t, next[axis]);
    if (!(t <= t1)) break;
    voxel[axis] += step[axis];
    next[axis] = crossing(axis);
  }
  if (in_run) walk.segments.push_back({run_start, t1});
  return walk;
}

std::array<float, 3> gsm_optical_axis(const std::array<float, 16>& pose) {
  std::array<float, 3> axis{pose[2], pose[6], pose[10]};
  const float norm = std::sqrt(axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]);
  for (float& c : axis) c /= norm;
  return axis;
}

GsmPixelRay march_gsm_pixel(const VoxelRayGrid& grid, const std::array<float, 16>& pose,
                            const std::array<float, 6>& intrinsics, int64_t u, int64_t v) {
  const std::array<double, 3> centre{pose[3], pose[7], pose[11]};
  const std::array<float, 3> dir = gsm_pixel_ray_direction(pose, intrinsics, u, v);
  const VoxelRayWalk walk = grid.march(centre, {dir[0], dir[1], dir[2]});
  GsmPixelRay r;
  r.first_voxel = walk.first_voxel;
  r.grid_foreground = walk.first_segment_start(kGsmGridMaskMinSegment) >= 0.0 ? 1 : 0;
  const double start = walk.first_segment_start(kGsmDepthMinSegment);
  if (start >= 0.0) {
    // The optical axis in float32 as the official code computes it.
    const std::array<float, 3> axis = gsm_optical_axis(pose);
    const float cosine = axis[0] * dir[0] + axis[1] * dir[1] + axis[2] * dir[2];
    r.voxel_depth = static_cast<float>(start) * cosine;
  }
  return r;
}

void check_gsm_ray_intrinsics(const GsmInputs& in, int64_t b) {
  const int64_t N = in.views, H = in.height, W = in.width;
  for (int64_t view = 0; view < N; ++view) {
    const std::array<float, 6>& k = in.intrinsics[static_cast<size_t>(b * N + view)];
    if (static_cast<int64_t>(k[4]) != W || static_cast<int64_t>(k[5]) != H)
      throw std::invalid_argument("gsm pixel rays: intrinsics of view " + std::to_string(b * N + view) + " are for " +
                                  std::to_string(k[4]) + " x " + std::to_string(k[5]) + " pixels, the images have " +
                                  std::to_string(W) + " x " + std::to_string(H));
  }
}

void gsm_parallel_for(int64_t n, int64_t grain, const std::function<void(int64_t)>& fn) {
  if (n <= 0) return;
  grain = std::max<int64_t>(grain, 1);
  const int64_t tasks = (n + grain - 1) / grain;
  const size_t threads = std::min<size_t>(static_cast<size_t>(tasks), std::max(1u, std::thread::hardware_concurrency()));
  std::atomic<int64_t> next{0};
  std::vector<std::exception_ptr> errors(threads);
  auto work = [&](size_t tid) {
    try {
      for (int64_t task = next++; task < tasks; task = next++)
        for (int64_t i = task * grain; i < std::min(n, (task + 1) * grain); ++i) fn(i);
    } catch (...) {
      errors[tid] = std::current_exception();  // rethrown on the calling thread
    }
  };
  std::vector<std::thread> pool;
  for (size_t t = 1; t < threads; ++t) pool.emplace_back(work, t);
  work(0);
  for (std::thread& t : pool) t.join();
  for (const std::exception_ptr& e : errors)
    if (e) std::rethrow_exception(e);
}

GsmPixelRays cast_gsm_pixel_rays(const GsmInputs& in, int64_t batch_element) {
  const int64_t b = batch_element, N = in.views, H = in.height, W = in.width;
  const VoxelRayGrid grid(gsm_input_grid(in, b));
  check_gsm_ray_intrinsics(in, b);
  GsmPixelRays out;
  out.views = N;
  out.height = H;
  out.width = W;
  const size_t n = static_cast<size_t>(N * H * W);
  out.first_voxel.assign(n, -1);
  out.grid_foreground.assign(n, 0);
  out.voxel_depth.assign(n, 0.0f);
  // One image row per task; every pixel is independent, so the result does not depend on the threads.
  gsm_parallel_for(N * H, 1, [&](int64_t row) {
    const int64_t view = row / H, v = row % H;
    const std::array<float, 16>& pose = in.poses[static_cast<size_t>(b * N + view)];
    const std::array<float, 6>& k = in.intrinsics[static_cast<size_t>(b * N + view)];
    for (int64_t u = 0; u < W; ++u) {
      const GsmPixelRay r = march_gsm_pixel(grid, pose, k, u, v);
      const size_t p = static_cast<size_t>((view * H + v) * W + u);
      out.first_voxel[p] = r.first_voxel;
      out.grid_foreground[p] = r.grid_foreground;
      out.voxel_depth[p] = r.voxel_depth;
    }
  });
  return out;
}

void trace_gsm_pixel_rays(const std::vector<GsmPixelRays>& all_elements, GsmTrace* trace) {
  if (!trace || all_elements.empty()) return;
  const int64_t B = static_cast<int64_t>(all_elements.size());
  const GsmPixelRays& e0 = all_elements[0];
  const int64_t N = e0.views, H = e0.height, W = e0.width, per = N * H * W;
  CpuTensor mask({B, N, H, W}), depth({B, N, H, W});
  for (int64_t b = 0; b < B; ++b) {
    const GsmPixelRays& e = all_elements[static_cast<size_t>(b)];
    if (e.views != N || e.height != H || e.width != W)
      throw std::invalid_argument("trace gsm pixel rays: batch elements of different sizes");
    CpuTensor first({N, H, W});
    for (int64_t p = 0; p < per; ++p) {
      first.data[static_cast<size_t>(p)] = static_cast<float>(e.first_voxel[static_cast<size_t>(p)]);
      mask.data[static_cast<size_t>(b * per + p)] = e.grid_foreground[static_cast<size_t>(p)];
      depth.data[static_cast<size_t>(b * per + p)] = e.voxel_depth[static_cast<size_t>(p)];
    }
    trace_put(trace, "vox.lifter.pixel_first_voxel.b" + std::to_string(b), first);
  }
  trace_put(trace, "pre.grid_fg_mask", mask);
  trace_put(trace, "pix.voxel_depth", depth);
}

}  // namespace icube::nn

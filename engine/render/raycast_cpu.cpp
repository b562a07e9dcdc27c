// Brute-force double-precision voxel DDA; see raycast_cpu.h.
#include "render/raycast_cpu.h"

#include <algorithm>
#include <cmath>
#include <exception>
#include <stdexcept>
#include <thread>

namespace icube::render {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

double plane_t(int64_t plane, double o, double dd) { return (static_cast<double>(plane) - o) / dd; }
// Index-space planes where a ray with step `st` enters / leaves voxel v on one axis.
int64_t enter_plane(int64_t v, int st) { return st > 0 ? v : v + 1; }
int64_t exit_plane(int64_t v, int st) { return st > 0 ? v + 1 : v; }

// The voxel on one axis containing the ray at t: floor, then corrected with the
// plane formula the walk uses. A plane crossed exactly at t counts as crossed
// when `ties_crossed` (the axis comes before the entry axis in the x, y, z tie
// order), else the walk crosses it next with a zero-length step.
int64_t locate_axis(double o, double dd, int st, double t, bool ties_crossed) {
  int64_t v = static_cast<int64_t>(std::floor(o + t * dd));
  const double tn = plane_t(exit_plane(v, st), o, dd), tp = plane_t(enter_plane(v, st), o, dd);
  if (tn < t || (ties_crossed && tn == t))
    v += st;
  else if (tp > t || (!ties_crossed && tp == t))
    v -= st;
  return v;
}

}  // namespace

world::IjkBounds raycast_bounds(const world::VoxelGrid& grid) {
  world::IjkBounds b = grid.bounds();
  if (b.empty()) return b;
  b.min = world::brick_of(b.min) * world::kBrickDim;
  b.max = world::brick_of(b.max) * world::kBrickDim + (world::kBrickDim - 1);
  return b;
}

RayResult cast_ray_cpu(const world::VoxelGrid& grid, const world::IjkBounds& bounds, const Ray& ray,
                       const RaycastOptions& opts) {
  RayResult r;
  if (bounds.empty()) return r;
  const double vs = grid.voxel_size();
  const glm::dvec3 q = (ray.origin - grid.origin()) / vs;
  if (!std::isfinite(q.x) || !std::isfinite(q.y) || !std::isfinite(q.z)) throw std::invalid_argument("raycast: non-finite ray origin");
  int64_t ref[3], lo[3], hi[3];
  double o[3], dd[3];
  int st[3];
  for (int a = 0; a < 3; ++a) {
    const double f = std::floor(q[a]);
    if (std::fabs(f) > 4.0e15) throw std::invalid_argument("raycast: ray origin too far from the grid origin");
    ref[a] = static_cast<int64_t>(f);
    o[a] = q[a] - f;
    dd[a] = ray.dir[a] / vs;
    st[a] = dd[a] > 0.0 ? 1 : (dd[a] < 0.0 ? -1 : 0);
    lo[a] = bounds.min[a] - ref[a];
    hi[a] = static_cast<int64_t>(bounds.max[a]) + 1 - ref[a];
  }
  // Slab clip to the bounds; axes with dd == 0 never form (plane - o) / 0.
  double t0 = 0.0, t1 = opts.t_max;
  int eaxis = -1;
  for (int a = 0; a < 3; ++a) {
    if (st[a] == 0) {
      if (o[a] < static_cast<double>(lo[a]) || o[a] >= static_cast<double>(hi[a])) return r;
      continue;
    }
    const double ta = plane_t(lo[a], o[a], dd[a]), tb = plane_t(hi[a], o[a], dd[a]);
    const double tn = std::min(ta, tb), tf = std::max(ta, tb);
    if (tn >= t0) {  // ties: the last axis in x, y, z order is the entry face
      t0 = tn;
      eaxis = a;
    }
    t1 = std::min(t1, tf);
  }
  if (!(t0 < t1)) return r;

  int64_t v[3];
  double tm[3];
  for (int a = 0; a < 3; ++a) {
    if (a == eaxis)
      v[a] = st[a] > 0 ? lo[a] : hi[a] - 1;
    else if (st[a] == 0 || eaxis < 0)  // started inside: the half-open voxel containing the origin
      v[a] = std::clamp(static_cast<int64_t>(std::floor(o[a])), lo[a], hi[a] - 1);
    else
      v[a] = std::clamp(locate_axis(o[a], dd[a], st[a], t0, a < eaxis), lo[a], hi[a] - 1);
    tm[a] = st[a] == 0 ? kInf : plane_t(exit_plane(v[a], st[a]), o[a], dd[a]);
  }

  double t = t0;
  int normal = eaxis >= 0 ? -(eaxis + 1) * st[eaxis] : 0;
  bool in_run = false;
  double run_t = 0.0, run_len = 0.0, gap = 0.0;
  const world::Brick* brick = nullptr;
  glm::ivec3 brick_coord{0};
  bool brick_valid = false;
  for (;;) {
    ++r.steps;
    const int e = tm[0] <= tm[1] ? (tm[0] <= tm[2] ? 0 : 2) : (tm[1] <= tm[2] ? 1 : 2);
    const double tx = tm[e];
    const double chord = std::max(std::min(tx, t1) - t, 0.0);
    const glm::ivec3 ijk(static_cast<int32_t>(ref[0] + v[0]), static_cast<int32_t>(ref[1] + v[1]),
                         static_cast<int32_t>(ref[2] + v[2]));
    const glm::ivec3 bc = world::brick_of(ijk);
    if (!brick_valid || bc != brick_coord) {
      brick = grid.find_brick(bc);
      brick_coord = bc;
      brick_valid = true;
    }
    const int bit = world::voxel_bit(ijk);
    const bool occupied = brick && ((brick->mask[static_cast<size_t>(bit >> 6)] >> (bit & 63)) & 1u);
    if (occupied) {
      if (!r.sem_hit && chord >= opts.eps_sem) {
        r.sem_hit = true;
        r.t_sem = t;
        r.class_id = brick->classes[static_cast<size_t>(bit)];
        r.instance = brick->instances[static_cast<size_t>(bit)];
        r.ijk = ijk;
        r.normal = normal;
      }
      if (!r.depth_hit) {
        if (!in_run) {
          in_run = true;
          run_t = t;
          run_len = 0.0;
        }
        run_len += chord;
        gap = 0.0;
        if (run_len >= opts.eps_depth) {
          r.depth_hit = true;
          r.t_depth = run_t;
        }
      }
      if (r.sem_hit && r.depth_hit) break;
    } else if (in_run) {
      gap += chord;
      if (gap > opts.gap_eps) in_run = false;
    }
    if (tx >= t1) break;
    t = std::max(t, tx);
    v[e] += st[e];
    normal = -(e + 1) * st[e];
    tm[e] = plane_t(exit_plane(v[e], st[e]), o[e], dd[e]);
    if (v[e] < lo[e] || v[e] >= hi[e]) break;
  }
  return r;
}

std::vector<RayResult> cast_rays_cpu(const world::VoxelGrid& grid, const std::vector<Ray>& rays,
                                     const RaycastOptions& opts, unsigned threads) {
  const world::IjkBounds b = raycast_bounds(grid);
  std::vector<RayResult> out(rays.size());
  constexpr size_t kChunk = 64;
  const unsigned T = std::max(1u, threads);
  std::vector<std::exception_ptr> errors(T);
  auto work = [&](unsigned tid) {
    try {
      for (size_t c = static_cast<size_t>(tid) * kChunk; c < rays.size(); c += static_cast<size_t>(T) * kChunk)
        for (size_t i = c; i < std::min(rays.size(), c + kChunk); ++i) out[i] = cast_ray_cpu(grid, b, rays[i], opts);
    } catch (...) {
      errors[tid] = std::current_exception();  // rethrown on the calling thread
    }
  };
  if (T == 1) {
    work(0);
  } else {
    std::vector<std::thread> pool;
    for (unsigned t = 0; t < T; ++t) pool.emplace_back(work, t);
    for (std::thread& th : pool) th.join();
  }
  for (const std::exception_ptr& e : errors)
    if (e) std::rethrow_exception(e);
  return out;
}

std::vector<RayResult> cast_camera_cpu(const world::VoxelGrid& grid, const Camera& cam, const RaycastOptions& opts,
                                       unsigned threads) {
  return cast_rays_cpu(grid, camera_rays(cam, opts.pixels), opts, threads);
}

}  // namespace icube::render

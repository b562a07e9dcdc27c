// Helpers shared by the ray caster's tests (tests/render/test_raycast.cpp,
// tests/render/test_raycast_index.cpp): GPU hits as RayResults, the GPU / CPU agreement
// count with the first mismatches printed, cameras, and hit equality.
#pragma once

#include "render/raycast_cpu.h"
#include "render/raycast_gpu.h"

#include <doctest/doctest.h>
#include <glm/gtc/quaternion.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

namespace icube::raytest {

using render::Ray;
using render::RayResult;

inline RayResult from_gpu(const shader::RaycastHit& h) {
  RayResult r;
  r.sem_hit = (h.flags & RAYCAST_FLAG_SEM) != 0;
  r.depth_hit = (h.flags & RAYCAST_FLAG_DEPTH) != 0;
  r.t_sem = h.t_sem;
  r.t_depth = h.t_depth;
  r.class_id = static_cast<uint8_t>(h.sem_class);
  r.instance = static_cast<uint16_t>(h.sem_instance);
  r.ijk = {h.ijk_x, h.ijk_y, h.ijk_z};
  r.normal = h.normal;
  r.steps = h.steps;
  return r;
}

inline std::vector<RayResult> from_gpu(const std::vector<shader::RaycastHit>& h) {
  std::vector<RayResult> out;
  out.reserve(h.size());
  for (const auto& x : h) out.push_back(from_gpu(x));
  return out;
}

struct Agreement {
  size_t rays = 0, disagree = 0, sem_hits = 0, depth_hits = 0;
  size_t normal_only = 0;  // same voxel and t, other entry face: the ray crosses an edge within rounding
  double max_dt = 0.0;  // metres, over rays that agree
};

// Hit flags, voxel, class, instance must match and t agree within t_tol metres; a different
// entry face alone is counted separately (normal_only). Every difference is printed.
inline Agreement compare(const std::vector<RayResult>& gpu, const std::vector<RayResult>& cpu, double t_tol,
                  const char* what) {
  Agreement a;
  REQUIRE(gpu.size() == cpu.size());
  a.rays = gpu.size();
  for (size_t i = 0; i < gpu.size(); ++i) {
    const RayResult &g = gpu[i], &c = cpu[i];
    bool ok = g.sem_hit == c.sem_hit && g.depth_hit == c.depth_hit;
    double dt = 0.0;
    if (ok && c.sem_hit) {
      ok = g.ijk == c.ijk && g.class_id == c.class_id && g.instance == c.instance;
      dt = std::max(dt, std::fabs(g.t_sem - c.t_sem));
    }
    if (ok && c.depth_hit) dt = std::max(dt, std::fabs(g.t_depth - c.t_depth));
    if (ok && dt > t_tol) ok = false;
    const bool normal_only = ok && c.sem_hit && g.normal != c.normal;
    if (!ok || normal_only) {
      std::printf("  %s ray %zu: gpu sem %d (%d %d %d) cls %u n %d t %.7f depth %d %.7f | cpu sem %d (%d %d %d) cls %u n %d "
                  "t %.7f depth %d %.7f\n",
                  what, i, g.sem_hit, g.ijk.x, g.ijk.y, g.ijk.z, g.class_id, g.normal, g.t_sem, g.depth_hit, g.t_depth,
                  c.sem_hit, c.ijk.x, c.ijk.y, c.ijk.z, c.class_id, c.normal, c.t_sem, c.depth_hit, c.t_depth);
    }
    if (!ok) {
      ++a.disagree;
    } else {
      a.normal_only += normal_only;
      a.max_dt = std::max(a.max_dt, dt);
    }
    a.sem_hits += c.sem_hit;
    a.depth_hits += c.depth_hit;
  }
  return a;
}

inline void add(Agreement& total, const Agreement& a) {
  total.rays += a.rays;
  total.disagree += a.disagree;
  total.normal_only += a.normal_only;
  total.sem_hits += a.sem_hits;
  total.depth_hits += a.depth_hits;
  total.max_dt = std::max(total.max_dt, a.max_dt);
}

inline render::Camera make_camera(uint32_t w, uint32_t h, double f, const glm::dvec3& pos, const glm::dmat3& R) {
  render::Camera c;
  c.K = {f, f * 1.07, w * 0.5 - 0.3, h * 0.5 + 0.2, w, h};
  c.c2w = glm::dmat4(R);
  c.c2w[3] = glm::dvec4(pos, 1.0);
  return c;
}

// Camera looking from `pos` towards `target` (OpenCV axes, world z up).
inline glm::dmat3 look_at(const glm::dvec3& pos, const glm::dvec3& target) {
  const glm::dvec3 z = glm::normalize(target - pos);
  glm::dvec3 up(0.0, 0.0, 1.0);
  if (std::fabs(glm::dot(up, z)) > 0.99) up = {0.0, 1.0, 0.0};
  const glm::dvec3 x = glm::normalize(glm::cross(z, up));  // right
  const glm::dvec3 y = glm::cross(z, x);                   // down
  return glm::dmat3(x, y, z);
}

inline glm::dmat3 random_rotation(std::mt19937& rng) {
  std::normal_distribution<double> n;
  const glm::dquat q = glm::normalize(glm::dquat(n(rng), n(rng), n(rng), n(rng)));
  return glm::mat3_cast(q);
}

// Random scattered voxels in [-extent, extent]^3.

inline bool same_hit(const shader::RaycastHit& a, const shader::RaycastHit& b) {
  return a.flags == b.flags && a.sem_class == b.sem_class && a.sem_instance == b.sem_instance && a.ijk_x == b.ijk_x &&
         a.ijk_y == b.ijk_y && a.ijk_z == b.ijk_z && a.normal == b.normal && a.t_sem == b.t_sem &&
         a.t_depth == b.t_depth;
}

}  // namespace icube::raytest

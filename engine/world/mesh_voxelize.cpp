// Mesh -> box-frame 0.1 m sub-voxels -> 0.2 m world cells; see mesh_voxelize.h.
#include "world/mesh_voxelize.h"

#include "scene/frames.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>

namespace icube::world {
namespace {

constexpr double kTouchTolerance = 1e-9;  // metres: a triangle on a sub-voxel face counts for that sub-voxel

bool positive_finite(double v) { return std::isfinite(v) && v > 0.0; }

// Sub-voxel index range whose centres (i + 0.5)·s lie in [-half, half].
void centre_range(double half, double s, int& lo, int& hi) {
  lo = static_cast<int>(std::ceil(-half / s - 0.5 - 1e-9));
  hi = static_cast<int>(std::floor(half / s - 0.5 + 1e-9));
}

// Separating-axis test of a triangle against the closed cube centred at c
// with half-size h (Akenine-Möller 2001: 3 box axes, the triangle normal,
// 9 edge cross products).
bool triangle_overlaps_cube(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c_, const glm::dvec3& c,
                            double h) {
  const glm::dvec3 v[3] = {a - c, b - c, c_ - c};
  const glm::dvec3 e[3] = {v[1] - v[0], v[2] - v[1], v[0] - v[2]};
  auto separated = [&](const glm::dvec3& axis) {
    const double p0 = glm::dot(v[0], axis), p1 = glm::dot(v[1], axis), p2 = glm::dot(v[2], axis);
    const double r = h * (std::abs(axis.x) + std::abs(axis.y) + std::abs(axis.z));
    return std::min({p0, p1, p2}) > r || std::max({p0, p1, p2}) < -r;
  };
  for (int k = 0; k < 3; ++k) {
    const double lo = std::min({v[0][k], v[1][k], v[2][k]}), hi = std::max({v[0][k], v[1][k], v[2][k]});
    if (lo > h || hi < -h) return false;
  }
  for (int k = 0; k < 3; ++k) {
    glm::dvec3 unit(0.0);
    unit[k] = 1.0;
    for (const auto& edge : e)
      if (separated(glm::cross(unit, edge))) return false;
  }
  return !separated(glm::cross(e[0], e[1]));
}

}  // namespace

TriangleMesh fit_mesh_to_box(const TriangleMesh& mesh, double length, double width, double height) {
  TriangleMesh out;
  if (mesh.positions.empty() || mesh.triangles.empty()) return out;
  const MeshBounds b = mesh_bounds(mesh);
  const glm::dvec3 dims(length, width, height), ext = b.max - b.min, centre = 0.5 * (b.min + b.max);
  glm::dvec3 scale(0.0);
  for (int k = 0; k < 3; ++k) scale[k] = ext[k] > 0.0 ? dims[k] / ext[k] : 0.0;
  out.triangles = mesh.triangles;
  out.positions.reserve(mesh.positions.size());
  for (const auto& p : mesh.positions) {
    glm::dvec3 q = (p - centre) * scale;
    if (ext.z > 0.0) q.z = (p.z - b.min.z) * scale.z - 0.5 * height;  // bottom exactly on the box bottom
    out.positions.push_back(q);
  }
  return out;
}

BoxVoxelization voxelize_mesh_in_box(const TriangleMesh& mesh, double length, double width, double height,
                                     double sub_voxel) {
  BoxVoxelization out;
  out.sub_voxel = sub_voxel;
  if (!positive_finite(length) || !positive_finite(width) || !positive_finite(height) || !positive_finite(sub_voxel))
    return out;
  const TriangleMesh fitted = fit_mesh_to_box(mesh, length, width, height);
  if (fitted.triangles.empty()) return out;

  // Output: sub-voxels with centres in the box [lo, hi]. Shell and flood fill
  // run on every sub-voxel overlapping the box [clo, chi] (so the parts of the
  // mesh in a partial outer layer still close the shell) plus one padding
  // layer on every side, which is always outside.
  const glm::dvec3 half(0.5 * length, 0.5 * width, 0.5 * height);
  // Bounded before any int conversion or allocation (the work grid spans the box plus 3 layers).
  const double span = (length / sub_voxel + 3.0) * (width / sub_voxel + 3.0) * (height / sub_voxel + 3.0);
  if (span > static_cast<double>(kMaxBoxSubVoxels)) {
    char msg[200];
    std::snprintf(msg, sizeof msg, "a %g x %g x %g m box spans %.3g sub-voxels of %g m, more than the %zu allowed",
                  length, width, height, span, sub_voxel, kMaxBoxSubVoxels);
    throw std::invalid_argument(msg);
  }
  glm::ivec3 lo, hi, clo, chi;
  for (int k = 0; k < 3; ++k) {
    centre_range(half[k], sub_voxel, lo[k], hi[k]);
    clo[k] = static_cast<int>(std::floor(-half[k] / sub_voxel + 1e-9));
    chi[k] = static_cast<int>(std::ceil(half[k] / sub_voxel - 1e-9)) - 1;
  }
  if (lo.x > hi.x || lo.y > hi.y || lo.z > hi.z) return out;  // box thinner than one sub-voxel pitch
  const glm::ivec3 base = clo - 1, dim = chi - clo + 3;
  const size_t total = static_cast<size_t>(dim.x) * static_cast<size_t>(dim.y) * static_cast<size_t>(dim.z);
  enum : uint8_t { kUnknown = 0, kSurface = 1, kOutside = 2 };
  std::vector<uint8_t> state(total, kUnknown);
  auto at = [&](int i, int j, int k) {
    return (static_cast<size_t>(k - base.z) * static_cast<size_t>(dim.y) + static_cast<size_t>(j - base.y)) *
               static_cast<size_t>(dim.x) +
           static_cast<size_t>(i - base.x);
  };

  const double h = 0.5 * sub_voxel + kTouchTolerance;
  for (const auto& t : fitted.triangles) {
    const glm::dvec3 &a = fitted.positions[t.x], &b = fitted.positions[t.y], &c = fitted.positions[t.z];
    const glm::dvec3 tmin = glm::min(a, glm::min(b, c)), tmax = glm::max(a, glm::max(b, c));
    glm::ivec3 r0, r1;
    for (int k = 0; k < 3; ++k) {
      r0[k] = std::max(clo[k], static_cast<int>(std::floor((tmin[k] - kTouchTolerance) / sub_voxel)) - 1);
      r1[k] = std::min(chi[k], static_cast<int>(std::floor((tmax[k] + kTouchTolerance) / sub_voxel)) + 1);
    }
    for (int k = r0.z; k <= r1.z; ++k)
      for (int j = r0.y; j <= r1.y; ++j)
        for (int i = r0.x; i <= r1.x; ++i) {
          uint8_t& s = state[at(i, j, k)];
          if (s == kSurface) continue;
          const glm::dvec3 centre = (glm::dvec3(i, j, k) + 0.5) * sub_voxel;
          if (triangle_overlaps_cube(a, b, c, centre, h)) s = kSurface;
        }
  }

  // 6-connected flood fill of the outside from the padding corner.
  std::vector<glm::ivec3> stack{base};
  state[at(base.x, base.y, base.z)] = kOutside;
  const glm::ivec3 top = base + dim - 1;
  while (!stack.empty()) {
    const glm::ivec3 p = stack.back();
    stack.pop_back();
    for (int n = 0; n < 6; ++n) {
      glm::ivec3 q = p;
      q[n / 2] += (n % 2) ? 1 : -1;
      if (q.x < base.x || q.y < base.y || q.z < base.z || q.x > top.x || q.y > top.y || q.z > top.z) continue;
      uint8_t& s = state[at(q.x, q.y, q.z)];
      if (s != kUnknown) continue;
      s = kOutside;
      stack.push_back(q);
    }
  }

  for (int i = lo.x; i <= hi.x; ++i)
    for (int j = lo.y; j <= hi.y; ++j)
      for (int k = lo.z; k <= hi.z; ++k) {
        const uint8_t s = state[at(i, j, k)];
        if (s == kOutside) continue;
        (s == kSurface ? out.surface : out.interior) += 1;
        out.sub_voxels.emplace_back(i, j, k);
      }
  return out;
}

std::vector<VehicleVoxel> vote_into_cells(const BoxVoxelization& vox, const scene::BoxState& box, uint32_t instance_id,
                                          const VoteOptions& options) {
  std::vector<VehicleVoxel> out;
  if (vox.sub_voxels.empty()) return out;
  if (!positive_finite(options.cell)) throw std::invalid_argument("vote_into_cells: cell size must be positive");
  const glm::dmat3 rot = scene::box_rotation(box);
  // Whole cells of the box centre, split off in double so the rotation works on small numbers.
  const glm::dvec3 rel = box.center - options.grid_origin;
  glm::dvec3 whole = glm::floor(rel / options.cell);
  constexpr double kLimit = static_cast<double>(std::numeric_limits<int32_t>::max() / 2);
  if (!std::isfinite(whole.x) || !std::isfinite(whole.y) || !std::isfinite(whole.z) || std::abs(whole.x) > kLimit ||
      std::abs(whole.y) > kLimit || std::abs(whole.z) > kLimit)
    throw std::out_of_range("vote_into_cells: box centre is outside the int32 cell range (or not finite)");
  const glm::dvec3 frac = rel - whole * options.cell;
  const glm::ivec3 offset(whole);

  std::vector<glm::ivec3> cells;
  cells.reserve(vox.sub_voxels.size());
  for (const auto& s : vox.sub_voxels) {
    const glm::dvec3 local = (glm::dvec3(s) + 0.5) * vox.sub_voxel;
    const glm::dvec3 p = rot * local + frac;
    cells.push_back(offset + glm::ivec3(glm::floor(p / options.cell)));
  }
  auto less = [](const glm::ivec3& a, const glm::ivec3& b) {
    return a.x != b.x ? a.x < b.x : a.y != b.y ? a.y < b.y : a.z < b.z;
  };
  std::sort(cells.begin(), cells.end(), less);
  for (size_t i = 0; i < cells.size();) {
    size_t j = i;
    while (j < cells.size() && cells[j] == cells[i]) ++j;
    if (j - i >= options.min_sub_voxels)
      out.push_back({cells[i], options.class_id, instance_id, static_cast<uint32_t>(j - i)});
    i = j;
  }
  return out;
}

std::vector<VehicleVoxel> voxelize_vehicle(const TriangleMesh& mesh, const scene::BoxState& box, uint32_t instance_id,
                                           const VoteOptions& options) {
  return vote_into_cells(voxelize_mesh_in_box(mesh, box.length, box.width, box.height), box, instance_id, options);
}

}  // namespace icube::world

// Oriented box ∩ axis-aligned cell volume by face clipping; see box_overlap.h.
#include "world/box_overlap.h"

#include <array>
#include <cmath>

namespace icube::world {

namespace {

struct Plane {  // inside: dot(n, x) <= d
  glm::dvec3 n;
  double d;
};

constexpr int kMaxVerts = 4 + 6;

struct Poly {
  std::array<glm::dvec3, kMaxVerts> v;
  int count = 0;
};

// Sutherland–Hodgman: keeps the part of `in` with dot(n, x) <= d.
Poly clip(const Poly& in, const Plane& p) {
  Poly out;
  if (in.count == 0) return out;
  for (int i = 0; i < in.count; ++i) {
    const glm::dvec3& a = in.v[static_cast<size_t>(i)];
    const glm::dvec3& b = in.v[static_cast<size_t>((i + 1) % in.count)];
    const double da = glm::dot(p.n, a) - p.d, db = glm::dot(p.n, b) - p.d;
    // The count guards only matter for rounding-induced non-convexity (a convex polygon gains <= 1 vertex).
    if (da <= 0.0 && out.count < kMaxVerts) out.v[static_cast<size_t>(out.count++)] = a;
    if (((da < 0.0 && db > 0.0) || (da > 0.0 && db < 0.0)) && out.count < kMaxVerts) {
      const double t = da / (da - db);
      out.v[static_cast<size_t>(out.count++)] = a + (b - a) * t;
    }
  }
  return out;
}

// 1/3 · A · (x0 − o) for a planar polygon with outward (counter-clockwise) order.
double face_term(const Poly& f, const glm::dvec3& o) {
  if (f.count < 3) return 0.0;
  glm::dvec3 area(0.0);
  const glm::dvec3 v0 = f.v[0];
  for (int i = 1; i + 1 < f.count; ++i)
    area += glm::cross(f.v[static_cast<size_t>(i)] - v0, f.v[static_cast<size_t>(i + 1)] - v0);
  return glm::dot(area * 0.5, v0 - o) / 3.0;
}

// Faces of a box given centre c, unit axes u[k] and half extents h[k], each
// counter-clockwise seen from outside (normal +/- u[k]).
void box_faces(const glm::dvec3& c, const glm::dmat3& u, const glm::dvec3& h, std::array<Poly, 6>& faces,
               std::array<Plane, 6>& planes) {
  for (int k = 0; k < 3; ++k) {
    const glm::dvec3 a = u[(k + 1) % 3] * h[(k + 1) % 3], b = u[(k + 2) % 3] * h[(k + 2) % 3];
    for (int s = 0; s < 2; ++s) {
      const double sign = s == 0 ? 1.0 : -1.0;
      const glm::dvec3 n = u[k] * sign, fc = c + n * h[k];
      Poly& f = faces[static_cast<size_t>(2 * k + s)];
      f.count = 4;
      // (a, b, n) is right-handed for sign +1: a×b = +u[k] direction.
      if (s == 0) f.v = {fc - a - b, fc + a - b, fc + a + b, fc - a + b, {}, {}, {}, {}, {}, {}};
      else f.v = {fc - a - b, fc - a + b, fc + a + b, fc + a - b, {}, {}, {}, {}, {}, {}};
      planes[static_cast<size_t>(2 * k + s)] = {n, glm::dot(n, fc)};
    }
  }
}

bool degenerate(const OrientedBox& b) {
  for (int k = 0; k < 3; ++k)
    if (!(b.size[k] > 0.0) || !std::isfinite(b.size[k]) || !std::isfinite(b.center[k])) return true;
  return false;
}

}  // namespace

double box_cell_intersection_volume(const OrientedBox& box, const AxisBox& cell) {
  if (degenerate(box)) return 0.0;
  const glm::dvec3 ext = cell.hi - cell.lo;
  if (!(ext.x > 0.0 && ext.y > 0.0 && ext.z > 0.0)) return 0.0;
  // Work relative to the cell centre for precision.
  const glm::dvec3 o = (cell.lo + cell.hi) * 0.5;
  std::array<Poly, 6> cf, bf;
  std::array<Plane, 6> cp, bp;
  box_faces(glm::dvec3(0.0), glm::dmat3(1.0), ext * 0.5, cf, cp);
  box_faces(box.center - o, box.axes, box.size * 0.5, bf, bp);
  // Coplanar face pairs: a co-oriented pair is counted once (on the cell face,
  // which is then not clipped by its twin plane: rounding would decide it);
  // an opposite pair means the solids only touch.
  std::array<int, 6> cell_twin;
  cell_twin.fill(-1);
  std::array<bool, 6> box_twin{};
  for (size_t i = 0; i < 6; ++i)
    for (size_t j = 0; j < 6; ++j) {
      const double c = glm::dot(cp[j].n, bp[i].n);
      if (c > 1.0 - kCoplanarTolerance && std::abs(cp[j].d - bp[i].d) <= kCoplanarTolerance) {
        box_twin[i] = true;
        cell_twin[j] = static_cast<int>(i);
      }
      if (c < kCoplanarTolerance - 1.0 && std::abs(cp[j].d + bp[i].d) <= kCoplanarTolerance) return 0.0;
    }
  double vol = 0.0;
  for (size_t j = 0; j < 6; ++j) {  // cell faces clipped to the box
    Poly f = cf[j];
    for (size_t i = 0; i < 6; ++i)
      if (static_cast<int>(i) != cell_twin[j]) f = clip(f, bp[i]);
    vol += face_term(f, glm::dvec3(0.0));
  }
  for (size_t i = 0; i < 6; ++i) {  // box faces clipped to the cell
    if (box_twin[i]) continue;
    Poly f = bf[i];
    for (const Plane& p : cp) f = clip(f, p);
    vol += face_term(f, glm::dvec3(0.0));
  }
  return vol > 0.0 ? vol : 0.0;
}

BoxCellOverlap box_cell_overlap(const OrientedBox& box, const AxisBox& cell) {
  BoxCellOverlap r;
  r.intersection = box_cell_intersection_volume(box, cell);
  const glm::dvec3 ext = cell.hi - cell.lo;
  const double vb = degenerate(box) ? 0.0 : box.size.x * box.size.y * box.size.z;
  const double uni = vb + ext.x * ext.y * ext.z - r.intersection;
  r.iou = uni > 0.0 ? r.intersection / uni : 0.0;
  return r;
}

AxisBox box_bounds(const OrientedBox& box) {
  glm::dvec3 r(0.0);
  for (int k = 0; k < 3; ++k) r += glm::abs(box.axes[k]) * (box.size[k] * 0.5);
  return {box.center - r, box.center + r};
}

}  // namespace icube::world

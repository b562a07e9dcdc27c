// Exact volume of an oriented box ∩ an axis-aligned cube, and their IoU
// (CPU, double), for the Stage-1 box condition channels (conventions §7).
//
// Method: the intersection P = A ∩ B of two convex solids is bounded by
// (faces of A clipped to B) ∪ (faces of B clipped to A). Each face polygon is
// clipped independently against the other solid's 6 half-spaces with
// Sutherland–Hodgman (a quad gains at most one vertex per plane, so ≤ 10
// vertices — the same fixed-size scheme runs in shaders/world/cond_boxes.comp), and
// vol(P) = 1/3 Σ_faces A_f · (x_f − o) by the divergence theorem, where A_f is
// the polygon's outward area vector and o the cube centre. No cap polygons
// are needed because every face of P lies on a face of A or B.
//
// Coplanar faces (within kCoplanarTolerance, cosine and metres): when a box
// face lies on a cell face plane with the same outward normal, both clipped
// polygons are the same region; it is counted once, on the cell face, which
// is then not clipped by that box plane (the sign of a rounding error would
// decide). A box face on a cell face plane with the opposite normal means the
// solids only touch: the volume is 0.
// Degenerate boxes (any extent ≤ 0 or not finite) give exactly 0.
#pragma once

#include <glm/glm.hpp>

namespace icube::world {

// An oriented cuboid: centre, unit axes (columns of `axes`, right-handed) and
// full extents along them (x = length, y = width, z = height).
struct OrientedBox {
  glm::dvec3 center{0.0};
  glm::dmat3 axes{1.0};
  glm::dvec3 size{0.0};
};

// An axis-aligned box [lo, hi] (the latent voxel cube; need not be a cube).
struct AxisBox {
  glm::dvec3 lo{0.0}, hi{0.0};
};

inline constexpr double kCoplanarTolerance = 1e-9;  // metres and cosine

// Volume of box ∩ cell in m³ (≥ 0; 0 for disjoint, touching or degenerate input).
double box_cell_intersection_volume(const OrientedBox& box, const AxisBox& cell);

// IoU = inter / (vol(box) + vol(cell) − inter); 0 when the union is empty.
struct BoxCellOverlap {
  double intersection = 0.0;
  double iou = 0.0;
};
BoxCellOverlap box_cell_overlap(const OrientedBox& box, const AxisBox& cell);

// Axis-aligned bounds of the box (for rejection tests).
AxisBox box_bounds(const OrientedBox& box);

}  // namespace icube::world

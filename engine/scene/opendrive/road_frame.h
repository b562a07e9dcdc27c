// The road's (s, t, h) frame in 3D: reference line + elevation +
// superelevation (formats.md §2.3, as libOpenDRIVE's Road::get_xyz):
//   P(s) = (x, y, z(s)),  e_s = normalize(cos θ, sin θ, z'(s)),
//   e_⊥ = (−sin θ, cos θ, 0),
//   e_t = cos φ·e_⊥ + sin φ·(e_s × e_⊥),  e_h = e_s × e_t,
//   X(s, t, h) = P + t·e_t + h·e_h,
// with φ(s) the superelevation (positive: the road falls to the right, i.e.
// towards −t). Lateral <shape> and lane @level are not applied.
#pragma once

#include "scene/opendrive/reference_line.h"
#include "scene/opendrive/xodr_document.h"

#include <glm/glm.hpp>

namespace icube::scene::odr {

struct FramePoint {
  glm::dvec3 origin{0.0};  // P(s)
  glm::dvec3 e_t{0.0};
  glm::dvec3 e_h{0.0};
  double hdg = 0.0;
  glm::dvec3 at(double t, double h = 0.0) const { return origin + t * e_t + h * e_h; }
};

class RoadFrame {
 public:
  // Keeps references to `road` and `line`; both must outlive the frame.
  RoadFrame(const Road& road, const ReferenceLine& line) : road_(road), line_(line) {}
  FramePoint at(double s) const;
  glm::dvec3 xyz(double s, double t, double h = 0.0) const { return at(s).at(t, h); }

 private:
  const Road& road_;
  const ReferenceLine& line_;
};

}  // namespace icube::scene::odr

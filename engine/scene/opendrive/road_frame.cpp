// (s, t, h) -> xyz for one road (see road_frame.h).
#include "scene/opendrive/road_frame.h"

#include <cmath>

namespace icube::scene::odr {

FramePoint RoadFrame::at(double s) const {
  const Pose2 p = line_.at(s);
  FramePoint f;
  f.hdg = p.hdg;
  f.origin = {p.x, p.y, road_.elevation.value(s)};
  const double c = std::cos(p.hdg), sn = std::sin(p.hdg);
  const glm::dvec3 e_s = glm::normalize(glm::dvec3(c, sn, road_.elevation.slope(s)));
  const glm::dvec3 e_perp(-sn, c, 0.0);
  const double phi = road_.superelevation.value(s);
  f.e_t = std::cos(phi) * e_perp + std::sin(phi) * glm::cross(e_s, e_perp);
  f.e_h = glm::cross(e_s, f.e_t);
  return f;
}

}  // namespace icube::scene::odr

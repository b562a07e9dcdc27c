// Lateral positions (t) of the lane borders of a lane section at s
// (formats.md §2.3).
//
// Conventions: borders are indexed like odr::LaneSection: border k lies
// between side lanes k-1 and k (lanes ordered leftmost first), so border 0 is
// the outer border of the leftmost lane, border n_left is the centre line
// t0 = laneOffset(s), and the last border is the outer border of the
// rightmost lane. Widths accumulate outward from t0:
//   t_outer(+i) = t_outer(+(i-1)) + w_i,  t_outer(−i) = t_outer(−(i-1)) − w_i.
// A lane without <width> records but with <border> records takes its outer
// border directly from them as a signed t of the reference line; <width>
// wins when both exist. Records are evaluated at ds' = s − (s_section +
// sOffset), the record in force being the last with sOffset ≤ s − s_section.
// Lane heights (<height>) are not applied.
#pragma once

#include "scene/opendrive/xodr_document.h"

#include <vector>

namespace icube::scene::odr {

// Record in force at ds (distance from the section start); nullptr when none.
const Cubic* record_at(const std::vector<Cubic>& records, double ds);
double lane_width(const Lane& lane, double ds);
const RoadMark* mark_at(const Lane& lane, double ds);

// Fills `t` with border_count() values at road s (s_section = sec.s).
void section_borders(const LaneSection& sec, const CubicProfile& lane_offset, double s, std::vector<double>& t);

}  // namespace icube::scene::odr

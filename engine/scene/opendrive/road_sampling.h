// Samples every lane border of a road at the same s values, section by
// section: every `step` metres from the section start, plus the section end
// and every breakpoint inside the section (geometry starts, lane width /
// border / roadMark starts, laneOffset records) exactly; samples closer than
// 1e-7 m are merged. Sections shorter than 1e-9 m, or starting at or beyond
// the road's length, are skipped; the last one ends at the road's length.
#pragma once

#include "scene/opendrive/reference_line.h"
#include "scene/opendrive/road_frame.h"
#include "scene/opendrive/xodr_document.h"

#include <glm/glm.hpp>

#include <cstddef>
#include <vector>

namespace icube::scene::odr {

struct SectionSamples {
  size_t section = 0;            // index into Road::sections
  double s_begin = 0.0, s_end = 0.0;
  size_t borders = 0;            // LaneSection::border_count()
  std::vector<double> s;         // increasing; front() == s_begin, back() == s_end
  std::vector<FramePoint> frames;
  std::vector<double> t;         // t[i * borders + k]: border k at sample i
  std::vector<glm::dvec3> xyz;   // same layout, world position of border k at sample i
  double t_at(size_t i, size_t k) const { return t[i * borders + k]; }
  const glm::dvec3& point(size_t i, size_t k) const { return xyz[i * borders + k]; }
  // |width| of side lane j at sample i.
  double width(size_t i, size_t j) const;
};

struct SectionRange {
  size_t section = 0;
  double s_begin = 0.0, s_end = 0.0;
};

// The sections that are sampled, with their [s_begin, s_end] on the road.
std::vector<SectionRange> section_ranges(const Road& road);

// The s values of one section (see top of file).
std::vector<double> section_sample_s(const Road& road, const SectionRange& range, double step);

// Upper bound on the points sample_road + lane centres produce for the road.
double estimate_points(const Road& road, double step);

std::vector<SectionSamples> sample_road(const Road& road, const ReferenceLine& line, double step);

}  // namespace icube::scene::odr

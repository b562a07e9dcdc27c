// Map statistics of an OpenDRIVE file, for tests and `icube scene info`:
// road and junction counts, total reference-line length (sum of road@length),
// the reference line's elevation range (exact: every elevation cubic is
// evaluated at its interval ends and at its derivative's roots; also the
// range of the records' start heights, which is what a reader that only
// looks at record values reports, e.g. 8.83 m for Town07 whose profile
// peaks at 9.40 m inside a record), and the
// plan view's continuity: the largest distance between a geometry's end
// point and the next geometry's start (x, y) within a road, with the road,
// the geometry (index of the later one, 0-based) and its XML line.
#pragma once

#include "scene/input_error.h"
#include "scene/opendrive/xodr_document.h"

#include <cstddef>
#include <string>

namespace icube::scene::odr {

struct XodrStats {
  int rev_major = 1, rev_minor = 4;
  size_t roads = 0, junctions = 0, geometries = 0, lane_sections = 0;
  double reference_length = 0.0;  // metres
  double min_elevation = 0.0, max_elevation = 0.0;          // exact range of the elevation profiles
  double min_record_elevation = 0.0, max_record_elevation = 0.0;  // range of the records' start values `a`
  double max_gap = 0.0;           // metres
  std::string max_gap_road;       // road id, empty when no road has two geometries
  size_t max_gap_geometry = 0;
  int max_gap_line = 0;
};

// Throws InputError when a geometry cannot be evaluated.
XodrStats compute_stats(const Document& doc);

// Reads and parses `path` (throws InputError) and returns its statistics.
XodrStats read_xodr_stats(const std::string& path, Diagnostics* diag = nullptr);

}  // namespace icube::scene::odr

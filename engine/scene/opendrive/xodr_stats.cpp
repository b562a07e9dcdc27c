// OpenDRIVE map statistics (see xodr_stats.h).
#include "scene/opendrive/xodr_stats.h"

#include "scene/atomic_file.h"
#include "scene/opendrive/reference_line.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace icube::scene::odr {

namespace {

// Min and max of the cubic over ds in [0, len].
void cubic_range(const Cubic& c, double len, double& lo, double& hi) {
  auto take = [&](double ds) {
    if (!(ds >= 0.0 && ds <= len)) return;
    const double v = c.value(ds);
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  };
  take(0.0);
  take(len);
  // roots of b + 2c·x + 3d·x²
  const double qa = 3.0 * c.d, qb = 2.0 * c.c, qc = c.b;
  if (std::fabs(qa) < 1e-300) {
    if (std::fabs(qb) > 1e-300) take(-qc / qb);
    return;
  }
  const double disc = qb * qb - 4.0 * qa * qc;
  if (disc < 0.0) return;
  const double r = std::sqrt(disc);
  take((-qb + r) / (2.0 * qa));
  take((-qb - r) / (2.0 * qa));
}

}  // namespace

XodrStats compute_stats(const Document& doc) {
  XodrStats st;
  st.rev_major = doc.header.rev_major;
  st.rev_minor = doc.header.rev_minor;
  st.roads = doc.roads.size();
  st.junctions = doc.junctions.size();
  double lo = std::numeric_limits<double>::max(), hi = std::numeric_limits<double>::lowest();
  double rec_lo = 0.0, rec_hi = 0.0;
  bool any_record = false;
  for (const Road& road : doc.roads) {
    for (const Cubic& c : road.elevation.records) {
      rec_lo = any_record ? std::min(rec_lo, c.a) : c.a;
      rec_hi = any_record ? std::max(rec_hi, c.a) : c.a;
      any_record = true;
    }
    st.reference_length += road.length;
    st.geometries += road.geometries.size();
    st.lane_sections += road.sections.size();
    const std::vector<Cubic>& el = road.elevation.records;
    if (el.empty()) {
      lo = std::min(lo, 0.0);
      hi = std::max(hi, 0.0);
    }
    for (size_t k = 0; k < el.size(); ++k) {
      const double a = k == 0 ? 0.0 : std::max(0.0, el[k].s);
      const double b = k + 1 < el.size() ? std::min(road.length, el[k + 1].s) : road.length;
      if (b < a) continue;
      // Before its own start the first record holds its value at ds = 0 (CubicProfile).
      const double from = std::max(a, el[k].s);
      if (a < from) {
        lo = std::min(lo, el[k].a);
        hi = std::max(hi, el[k].a);
      }
      if (b >= from) {
        double rlo = std::numeric_limits<double>::max(), rhi = std::numeric_limits<double>::lowest();
        cubic_range(el[k], b - from, rlo, rhi);
        lo = std::min(lo, rlo);
        hi = std::max(hi, rhi);
      }
    }
    ReferenceLine line = [&] {
      try {
        return ReferenceLine(road.geometries);
      } catch (const GeometryError& e) {
        throw InputError(doc.file,
                         "road " + road.id + " geometry " + std::to_string(e.index) + " (line " + std::to_string(e.line) + ")",
                         e.what());
      }
    }();
    for (size_t i = 1; i < line.size(); ++i) {
      const Geometry& prev = line.piece(i - 1).geometry();
      const Geometry& next = line.piece(i).geometry();
      const Pose2 end = line.piece(i - 1).at(prev.length);
      const double gap = std::hypot(end.x - next.x, end.y - next.y);
      if (st.max_gap_road.empty() || gap > st.max_gap) {
        st.max_gap = gap;
        st.max_gap_road = road.id;
        st.max_gap_geometry = i;
        st.max_gap_line = next.line;
      }
    }
  }
  if (doc.roads.empty()) lo = hi = 0.0;
  st.min_elevation = lo;
  st.max_elevation = hi;
  st.min_record_elevation = rec_lo;
  st.max_record_elevation = rec_hi;
  return st;
}

XodrStats read_xodr_stats(const std::string& path, Diagnostics* diag) {
  const std::string data = read_file(path);
  return compute_stats(parse_document(data.data(), data.size(), path, diag));
}

}  // namespace icube::scene::odr

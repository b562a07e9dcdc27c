// Evaluates an OpenDRIVE road reference line (planView) at s: position x, y
// and heading for line, arc, spiral, poly3 and paramPoly3 records.
//
// Conventions (formats.md §2.1):
//  - every record starts from its own x, y, hdg (nothing is integrated
//    across records); ds = s - s_k is clamped to [0, length];
//  - arc: chord form x = x0 + ds·sinc(κ·ds/2)·cos(θ0 + κ·ds/2), stable for
//    any κ (κ = 0 is a line);
//  - spiral: θ(ds) = θ0 + κ0·ds + c·ds²/2 with c = (κ1-κ0)/L, position by
//    8-point Gauss–Legendre integration of (cos θ, sin θ) from a table of
//    nodes spaced so θ turns ≤ 0.5 rad per node interval (≤ 2^17 nodes);
//    |κ1-κ0| < 1e-12 or L < 1e-9 is treated as an arc;
//  - poly3: u ≠ s; u(ds) inverts an arc-length table of ∫√(1+v'²)du;
//  - paramPoly3: p in [0, L] (arcLength) or [0, 1] (normalized); sampled at
//    true arc length by inverting a table of ∫|(u',v')|dp, scaled so that
//    ds = L lands on the parameter's end (p is only approximately s).
// Tables hold ≤ 2^16 intervals, and a road's records share 2^22 table nodes
// (so absurd inputs cost bounded memory). Nothing divides by a length below 1e-9.
#pragma once

#include "scene/opendrive/xodr_document.h"

#include <stdexcept>
#include <string>
#include <vector>

namespace icube::scene::odr {

// A plan-view record that cannot be evaluated; names its index in the road.
class GeometryError : public std::domain_error {
 public:
  GeometryError(size_t geometry_index, int xml_line, const std::string& what)
      : std::domain_error(what), index(geometry_index), line(xml_line) {}
  size_t index;
  int line;
};

struct Pose2 {
  double x = 0.0, y = 0.0, hdg = 0.0;
};

// One plan-view record prepared for evaluation. Throws std::domain_error when
// the record's curve is not finite (e.g. a paramPoly3 whose length overflows).
class GeometryEval {
 public:
  // max_nodes bounds the record's table (the reference line shares 2^22 nodes among its records).
  explicit GeometryEval(const Geometry& g, int max_nodes = 1 << 17);
  Pose2 at(double ds) const;
  const Geometry& geometry() const { return g_; }

 private:
  Pose2 local_poly(double u) const;   // poly3 at parameter u
  Pose2 local_param(double p) const;  // paramPoly3 at parameter p
  double speed(double q) const;       // |d(curve)/d(parameter)|
  double integrate_speed(double q0, double q1) const;
  double invert_arc_length(double sigma) const;  // parameter where the arc length from 0 is sigma
  void build_arc_table(double q_end, int intervals);
  Pose2 spiral(double ds) const;

  Geometry g_;
  GeometryKind kind_;  // after degenerate reductions (spiral -> arc -> line)
  double arc_k_ = 0.0;
  double spiral_c_ = 0.0, spiral_h_ = 0.0;
  std::vector<double> nx_, ny_;            // spiral node positions
  std::vector<double> q_, arc_;            // parameter nodes and arc length at them (poly3, paramPoly3)
  double arc_scale_ = 1.0;                 // paramPoly3: table arc length per unit of ds
  int max_nodes_ = 1 << 17;
};

class ReferenceLine {
 public:
  // `geometries` sorted by s, non-empty. Throws GeometryError.
  explicit ReferenceLine(const std::vector<Geometry>& geometries);
  Pose2 at(double s) const;
  size_t size() const { return pieces_.size(); }
  const GeometryEval& piece(size_t i) const { return pieces_[i]; }

 private:
  std::vector<GeometryEval> pieces_;
  std::vector<double> starts_;
};

// 8-point Gauss–Legendre nodes/weights on [-1, 1] (shared with tests and profiles).
inline constexpr int kGaussPoints = 8;
extern const double kGaussX[kGaussPoints];
extern const double kGaussW[kGaussPoints];

}  // namespace icube::scene::odr

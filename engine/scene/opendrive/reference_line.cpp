// Reference-line evaluation for OpenDRIVE plan-view records (see reference_line.h).
#include "scene/opendrive/reference_line.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace icube::scene::odr {

const double kGaussX[kGaussPoints] = {-0.9602898564975362, -0.7966664774136267, -0.5255324099163290,
                                      -0.1834346424956498, 0.1834346424956498,  0.5255324099163290,
                                      0.7966664774136267,  0.9602898564975362};
const double kGaussW[kGaussPoints] = {0.1012285362903763, 0.2223810344533745, 0.3137066458778873,
                                      0.3626837833783620, 0.3626837833783620, 0.3137066458778873,
                                      0.2223810344533745, 0.1012285362903763};

namespace {

constexpr double kTinyLength = 1e-9;
constexpr int kMaxSpiralNodes = 1 << 17;
constexpr int kMaxTableIntervals = 1 << 16;

// sin(x)/x, accurate near 0.
double sinc(double x) {
  if (std::fabs(x) < 1e-4) return 1.0 - x * x / 6.0 + x * x * x * x / 120.0;
  return std::sin(x) / x;
}

int table_intervals(double length, int max_nodes) {
  const double n = std::ceil(length / 1.0);
  return static_cast<int>(std::clamp(n, 4.0, static_cast<double>(std::min(kMaxTableIntervals, max_nodes))));
}

}  // namespace

GeometryEval::GeometryEval(const Geometry& g, int max_nodes)
    : g_(g), kind_(g.kind) {
  max_nodes_ = std::clamp(max_nodes, 16, kMaxSpiralNodes);
  const double L = g.length;
  switch (g.kind) {
    case GeometryKind::Line: break;
    case GeometryKind::Arc: arc_k_ = g.curvature; break;
    case GeometryKind::Spiral: {
      if (L < kTinyLength || std::fabs(g.curv_end - g.curv_start) < 1e-12) {
        kind_ = GeometryKind::Arc;
        arc_k_ = 0.5 * (g.curv_start + g.curv_end);
        break;
      }
      spiral_c_ = (g.curv_end - g.curv_start) / L;
      const double kmax = std::max(std::fabs(g.curv_start), std::fabs(g.curv_end));
      const double h0 = kmax > 0.0 ? std::min(4.0, 0.5 / kmax) : 4.0;
      const int n = static_cast<int>(std::clamp(std::ceil(L / h0), 1.0, static_cast<double>(max_nodes_)));
      spiral_h_ = L / n;
      nx_.assign(static_cast<size_t>(n) + 1, g.x);
      ny_.assign(static_cast<size_t>(n) + 1, g.y);
      for (int i = 0; i < n; ++i) {
        const double u0 = i * spiral_h_, u1 = (i + 1) * spiral_h_;
        const double m = 0.5 * (u0 + u1), r = 0.5 * (u1 - u0);
        double dx = 0.0, dy = 0.0;
        for (int k = 0; k < kGaussPoints; ++k) {
          const double u = m + r * kGaussX[k];
          const double th = g.hdg + u * (g.curv_start + 0.5 * spiral_c_ * u);
          dx += kGaussW[k] * std::cos(th);
          dy += kGaussW[k] * std::sin(th);
        }
        nx_[i + 1] = nx_[i] + r * dx;
        ny_[i + 1] = ny_[i] + r * dy;
      }
      break;
    }
    case GeometryKind::Poly3: {
      // u_end where ∫0^u √(1+v'²) = L; u_end <= L because the integrand is >= 1.
      build_arc_table(L, table_intervals(L, max_nodes_));
      if (!std::isfinite(arc_.back()) || arc_.back() > 1e12)
        throw std::domain_error("poly3 arc length is not finite");
      const double u_end = invert_arc_length(L);
      build_arc_table(u_end, table_intervals(L, max_nodes_));
      break;
    }
    case GeometryKind::ParamPoly3: {
      const double p_end = g.normalized ? 1.0 : L;
      build_arc_table(p_end, table_intervals(L, max_nodes_));
      const double total = arc_.back();
      if (!std::isfinite(total) || total > 1e12) throw std::domain_error("paramPoly3 arc length is not finite");
      arc_scale_ = L >= kTinyLength ? total / L : 0.0;
      break;
    }
  }
}

double GeometryEval::speed(double q) const {
  if (g_.kind == GeometryKind::Poly3) {
    const double dv = g_.b + q * (2.0 * g_.c + q * 3.0 * g_.d);
    return std::sqrt(1.0 + dv * dv);
  }
  const double du = g_.bu + q * (2.0 * g_.cu + q * 3.0 * g_.du);
  const double dv = g_.bv + q * (2.0 * g_.cv + q * 3.0 * g_.dv);
  return std::hypot(du, dv);
}

double GeometryEval::integrate_speed(double q0, double q1) const {
  const double m = 0.5 * (q0 + q1), r = 0.5 * (q1 - q0);
  double sum = 0.0;
  for (int k = 0; k < kGaussPoints; ++k) sum += kGaussW[k] * speed(m + r * kGaussX[k]);
  return r * sum;
}

void GeometryEval::build_arc_table(double q_end, int intervals) {
  q_.resize(static_cast<size_t>(intervals) + 1);
  arc_.assign(static_cast<size_t>(intervals) + 1, 0.0);
  for (int i = 0; i <= intervals; ++i) q_[i] = q_end * i / intervals;
  for (int i = 0; i < intervals; ++i) arc_[i + 1] = arc_[i] + integrate_speed(q_[i], q_[i + 1]);
}

double GeometryEval::invert_arc_length(double sigma) const {
  const double total = arc_.back();
  if (!(total > 0.0)) return q_.front();
  sigma = std::clamp(sigma, 0.0, total);
  size_t i = static_cast<size_t>(std::upper_bound(arc_.begin(), arc_.end(), sigma) - arc_.begin());
  i = std::min(std::max<size_t>(i, 1), arc_.size() - 1) - 1;
  double lo = q_[i], hi = q_[i + 1];
  const double span = arc_[i + 1] - arc_[i];
  double q = span > 0.0 ? lo + (sigma - arc_[i]) / span * (hi - lo) : lo;
  for (int iter = 0; iter < 40; ++iter) {
    const double f = arc_[i] + integrate_speed(q_[i], q) - sigma;
    if (std::fabs(f) < 1e-12) break;
    if (f > 0.0) hi = q;
    else lo = q;
    const double fp = speed(q);
    double next = fp > 1e-12 ? q - f / fp : 0.5 * (lo + hi);
    if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
    if (std::fabs(next - q) <= 1e-15 * (1.0 + std::fabs(q))) {
      q = next;
      break;
    }
    q = next;
  }
  return q;
}

Pose2 GeometryEval::local_poly(double u) const {
  const double v = g_.a + u * (g_.b + u * (g_.c + u * g_.d));
  const double dv = g_.b + u * (2.0 * g_.c + u * 3.0 * g_.d);
  const double c = std::cos(g_.hdg), s = std::sin(g_.hdg);
  return {g_.x + u * c - v * s, g_.y + u * s + v * c, g_.hdg + std::atan(dv)};
}

Pose2 GeometryEval::local_param(double p) const {
  const double u = g_.au + p * (g_.bu + p * (g_.cu + p * g_.du));
  const double v = g_.av + p * (g_.bv + p * (g_.cv + p * g_.dv));
  const double du = g_.bu + p * (2.0 * g_.cu + p * 3.0 * g_.du);
  const double dv = g_.bv + p * (2.0 * g_.cv + p * 3.0 * g_.dv);
  const double c = std::cos(g_.hdg), s = std::sin(g_.hdg);
  const double turn = (du == 0.0 && dv == 0.0) ? 0.0 : std::atan2(dv, du);
  return {g_.x + u * c - v * s, g_.y + u * s + v * c, g_.hdg + turn};
}

Pose2 GeometryEval::spiral(double ds) const {
  const int n = static_cast<int>(nx_.size()) - 1;
  const int i = std::clamp(static_cast<int>(ds / spiral_h_), 0, n - 1);
  const double u0 = i * spiral_h_;
  const double m = 0.5 * (u0 + ds), r = 0.5 * (ds - u0);
  double dx = 0.0, dy = 0.0;
  for (int k = 0; k < kGaussPoints; ++k) {
    const double u = m + r * kGaussX[k];
    const double th = g_.hdg + u * (g_.curv_start + 0.5 * spiral_c_ * u);
    dx += kGaussW[k] * std::cos(th);
    dy += kGaussW[k] * std::sin(th);
  }
  return {nx_[i] + r * dx, ny_[i] + r * dy, g_.hdg + ds * (g_.curv_start + 0.5 * spiral_c_ * ds)};
}

Pose2 GeometryEval::at(double ds) const {
  ds = std::clamp(ds, 0.0, g_.length);
  switch (kind_) {
    case GeometryKind::Line:
      return {g_.x + ds * std::cos(g_.hdg), g_.y + ds * std::sin(g_.hdg), g_.hdg};
    case GeometryKind::Arc: {
      const double half = 0.5 * arc_k_ * ds;
      const double chord = ds * sinc(half);
      return {g_.x + chord * std::cos(g_.hdg + half), g_.y + chord * std::sin(g_.hdg + half), g_.hdg + 2.0 * half};
    }
    case GeometryKind::Spiral: return spiral(ds);
    case GeometryKind::Poly3: return local_poly(invert_arc_length(ds));
    case GeometryKind::ParamPoly3: {
      if (arc_.back() > 1e-12 && arc_scale_ > 0.0) return local_param(invert_arc_length(ds * arc_scale_));
      const double p_end = q_.back();
      return local_param(g_.length >= kTinyLength ? ds / g_.length * p_end : 0.0);
    }
  }
  return {g_.x, g_.y, g_.hdg};
}

ReferenceLine::ReferenceLine(const std::vector<Geometry>& geometries) {
  pieces_.reserve(geometries.size());
  const int share = static_cast<int>(std::min<size_t>(1 << 17, (size_t{1} << 22) / std::max<size_t>(geometries.size(), 1)));
  for (size_t i = 0; i < geometries.size(); ++i) {
    try {
      pieces_.emplace_back(geometries[i], share);
    } catch (const std::domain_error& e) {
      throw GeometryError(i, geometries[i].line, e.what());
    }
    starts_.push_back(geometries[i].s);
  }
}

Pose2 ReferenceLine::at(double s) const {
  size_t i = static_cast<size_t>(std::upper_bound(starts_.begin(), starts_.end(), s) - starts_.begin());
  i = i == 0 ? 0 : i - 1;
  return pieces_[i].at(s - starts_[i]);
}

}  // namespace icube::scene::odr

// Screenshot checks; see screenshot_check.h.
#include "screenshot_check.h"

#include "world/semantics.h"

#include <cmath>
#include <stdexcept>

namespace icube::viewer {

namespace {

int palette_entry(const uint8_t* p) {
  for (size_t e = 0; e < world::kGuidancePalette.size(); ++e)
    if (p[0] == world::kGuidancePalette[e][0] && p[1] == world::kGuidancePalette[e][1] && p[2] == world::kGuidancePalette[e][2])
      return static_cast<int>(e);
  return 10;
}

// view/shade.comp's sky: mix(kSkyLow, kSkyHigh, s) for s in [0, 1].
constexpr double kSkyLow[3] = {0.78, 0.85, 0.93}, kSkyHigh[3] = {0.33, 0.53, 0.82};

bool on_sky_gradient(const uint8_t* p) {
  double num = 0.0, den = 0.0;
  for (int c = 0; c < 3; ++c) {
    const double d = kSkyHigh[c] - kSkyLow[c];
    num += (p[c] / 255.0 - kSkyLow[c]) * d;
    den += d * d;
  }
  const double s = std::fmin(1.0, std::fmax(0.0, num / den));
  double err = 0.0;
  for (int c = 0; c < 3; ++c) err = std::fmax(err, std::fabs(p[c] / 255.0 - (kSkyLow[c] + s * (kSkyHigh[c] - kSkyLow[c]))));
  return err <= 3.0 / 255.0;
}

}  // namespace

ClassHistogram semantic_histogram(const std::vector<uint8_t>& px, int channels) {
  ClassHistogram h{};
  const size_t step = static_cast<size_t>(channels);
  for (size_t i = 0; i + step <= px.size(); i += step) h[static_cast<size_t>(palette_entry(&px[i]))] += 1.0;
  return h;
}

ClassHistogram shaded_histogram(const std::vector<uint8_t>& px, int channels) {
  ClassHistogram h{};
  const size_t step = static_cast<size_t>(channels);
  for (size_t i = 0; i + step <= px.size(); i += step) {
    const uint8_t* p = &px[i];
    size_t k = 10;
    const double len = std::sqrt(double(p[0]) * p[0] + double(p[1]) * p[1] + double(p[2]) * p[2]);
    if (on_sky_gradient(p)) {
      k = 8;
    } else if (len > 0.0) {
      double best = -2.0;
      for (size_t e = 0; e < world::kGuidancePalette.size(); ++e) {
        if (e == 8) continue;  // sky is the gradient, not a lit class
        const auto& q = world::kGuidancePalette[e];
        const double ql = std::sqrt(double(q[0]) * q[0] + double(q[1]) * q[1] + double(q[2]) * q[2]);
        const double cosv = (double(p[0]) * q[0] + double(p[1]) * q[1] + double(p[2]) * q[2]) / (len * ql);
        if (cosv > best) {
          best = cosv;
          k = e;
        }
      }
    }
    h[k] += 1.0;
  }
  return h;
}

double histogram_l1(const ClassHistogram& a, const ClassHistogram& b, double n) {
  double l1 = 0.0;
  for (size_t k = 0; k < a.size(); ++k) l1 += std::fabs(a[k] - b[k]) / n;
  return l1;
}

SemanticComparison compare_semantic(const std::vector<uint8_t>& viewer_px, int viewer_channels,
                                    const std::vector<uint8_t>& buffer_px, int buffer_channels) {
  const size_t vc = static_cast<size_t>(viewer_channels), bc = static_cast<size_t>(buffer_channels);
  if (vc < 3 || bc < 3 || viewer_px.size() / vc != buffer_px.size() / bc)
    throw std::invalid_argument("compare_semantic: the pictures differ in size or channels");
  SemanticComparison r;
  r.pixels = viewer_px.size() / vc;
  for (size_t i = 0; i < r.pixels; ++i) {
    const uint8_t* a = &viewer_px[i * vc];
    const uint8_t* b = &buffer_px[i * bc];
    if (a[0] == b[0] && a[1] == b[1] && a[2] == b[2]) {
      ++r.equal;
    } else if (palette_entry(b) == 10 && palette_entry(a) == 3) {
      ++r.instance;
    } else {
      if (r.mismatched == 0) r.first_mismatch = i;
      ++r.mismatched;
    }
  }
  return r;
}

}  // namespace icube::viewer

// Checks that the viewer's pictures show the world they should (CPU only;
// library icube_viewer_core; used by icube-view's screenshots, its
// --compare-semantic mode and tests/viewer/test_viewer_checks.cpp).
//
// Histograms have 11 bins: the 10 guidance palette entries (world/semantics.h)
// and "other".
//  - semantic_histogram: exact palette colours (the semantic mode's pixels).
//  - shaded_histogram: the shaded mode's pixels. A pixel on the sky gradient
//    (view/shade.comp's two end colours, within 3/255 of the segment between
//    them) is sky (entry 8); else the palette entry whose RGB direction is
//    nearest (largest cosine) to the pixel's, since sun and ambient light
//    scale a class colour; black pixels are "other".
// compare_semantic: the viewer's semantic picture against `icube buffers`'
// semantic_buffer PNG of the same pose: equal pixels, plus pixels where the
// buffer shows an instance colour (any non-palette colour: PuRd, per
// instance) and the viewer shows the vehicle entry (3), count as matching.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace icube::viewer {

using ClassHistogram = std::array<double, 11>;

// `px`: `channels` bytes per pixel (3 or 4), RGB first.
ClassHistogram semantic_histogram(const std::vector<uint8_t>& px, int channels = 4);
ClassHistogram shaded_histogram(const std::vector<uint8_t>& px, int channels = 4);
// Sum |a - b| / n.
double histogram_l1(const ClassHistogram& a, const ClassHistogram& b, double n);

struct SemanticComparison {
  size_t pixels = 0;
  size_t equal = 0;      // same RGB
  size_t instance = 0;   // buffer: instance colour, viewer: vehicle entry
  size_t mismatched = 0;
  size_t first_mismatch = 0;  // pixel index of the first mismatch (when mismatched > 0)
  double mismatch_fraction() const { return pixels ? static_cast<double>(mismatched) / static_cast<double>(pixels) : 0.0; }
};
// Both RGB(A) with the given channel counts and the same pixel count (else std::invalid_argument).
SemanticComparison compare_semantic(const std::vector<uint8_t>& viewer_px, int viewer_channels,
                                    const std::vector<uint8_t>& buffer_px, int buffer_channels);

// Shaded-screenshot L1 limit against the headless buffer's histogram (the shaded classification is coarser).
inline constexpr double kShadedL1 = 0.05;

}  // namespace icube::viewer

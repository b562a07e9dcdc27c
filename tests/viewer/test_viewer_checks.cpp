// viewer/screenshot_check.h: class histograms of semantic and shaded
// pictures and the semantic comparison with `icube buffers`' PNGs, on
// hand-made pixels; engine/scene/png_read.h round trip.
#include <doctest/doctest.h>

#include "scene/png_read.h"
#include "scene/png_write.h"
#include "screenshot_check.h"
#include "world/semantics.h"

#include <filesystem>
#include <vector>

using namespace icube;

namespace {

void put(std::vector<uint8_t>& px, const std::array<uint8_t, 3>& c, double scale = 1.0) {
  for (int k = 0; k < 3; ++k) px.push_back(static_cast<uint8_t>(c[static_cast<size_t>(k)] * scale + 0.5));
  px.push_back(255);
}

}  // namespace

TEST_CASE("viewer checks: semantic and shaded histograms") {
  std::vector<uint8_t> px;
  put(px, world::kGuidancePalette[7]);
  put(px, world::kGuidancePalette[7]);
  put(px, world::kGuidancePalette[3]);
  put(px, {1, 2, 3});
  const viewer::ClassHistogram h = viewer::semantic_histogram(px);
  CHECK(h[7] == 2.0);
  CHECK(h[3] == 1.0);
  CHECK(h[10] == 1.0);

  // Lit class colours keep their direction; the sky gradient (view/shade.comp) is sky.
  std::vector<uint8_t> sh;
  put(sh, world::kGuidancePalette[6], 0.55);  // building in shadow
  put(sh, world::kGuidancePalette[4], 0.9);   // vegetation
  put(sh, world::kGuidancePalette[7], 0.3);   // dark road
  put(sh, {199, 217, 237});                   // sky near the horizon: (0.78, 0.85, 0.93)
  put(sh, {143, 176, 224});                   // halfway up the gradient
  put(sh, {0, 0, 0});
  const viewer::ClassHistogram s = viewer::shaded_histogram(sh);
  CHECK(s[6] == 1.0);
  CHECK(s[4] == 1.0);
  CHECK(s[7] == 1.0);
  CHECK(s[8] == 2.0);
  CHECK(s[10] == 1.0);
  CHECK(viewer::histogram_l1(h, h, 4.0) == 0.0);
  CHECK(viewer::histogram_l1(h, s, 6.0) > 0.5);
}

TEST_CASE("viewer checks: semantic comparison counts instance colours on vehicles as matching") {
  std::vector<uint8_t> a, b;
  put(a, world::kGuidancePalette[7]);  // equal
  put(b, world::kGuidancePalette[7]);
  put(a, world::kGuidancePalette[3]);  // vehicle vs a PuRd instance colour
  put(b, {221, 28, 119});
  put(a, world::kGuidancePalette[8]);  // sky vs an instance colour: a mismatch
  put(b, {221, 28, 119});
  put(a, world::kGuidancePalette[6]);  // building vs road: a mismatch
  put(b, world::kGuidancePalette[7]);
  const viewer::SemanticComparison c = viewer::compare_semantic(a, 4, b, 4);
  CHECK(c.pixels == 4);
  CHECK(c.equal == 1);
  CHECK(c.instance == 1);
  CHECK(c.mismatched == 2);
  CHECK(c.first_mismatch == 2);
  CHECK(c.mismatch_fraction() == doctest::Approx(0.5));
  std::vector<uint8_t> short_b(b.begin(), b.end() - 4);
  CHECK_THROWS_AS(viewer::compare_semantic(a, 4, short_b, 4), std::invalid_argument);

  // PNG round trip (RGBA written, RGB read).
  const std::string path = (std::filesystem::temp_directory_path() / "icube_viewer_checks.png").string();
  scene::write_png(path, a.data(), 2, 2, 4);
  const scene::Image8 img = scene::read_png(path, 3);
  CHECK(img.width == 2);
  CHECK(img.height == 2);
  REQUIRE(img.pixels.size() == 12);
  CHECK(img.pixels[3] == world::kGuidancePalette[3][0]);
  std::filesystem::remove(path);
  CHECK_THROWS_AS(scene::read_png(path, 3), std::runtime_error);
}

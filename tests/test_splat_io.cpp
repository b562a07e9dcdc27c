// 3DGS .ply reading and writing (engine/splat/gaussians.h): the real file in
// ../shared/data/splats (SH3, trailing bytes), binary and ASCII, every SH
// degree, extra and missing properties, activations, write/read round trip,
// and one-line errors for NaN/Inf values and zero quaternions.
#include <doctest/doctest.h>

#include "gpu_test_context.h"
#include "scene/input_error.h"
#include "splat/gaussians.h"
#include "test_splat_util.h"

#include <cmath>
#include <cstring>
#include <filesystem>
#include <sstream>
#include <string>

using namespace icube;

namespace {

// An ASCII/binary 3DGS file with SH degree `deg`, property order shuffled a little and an extra property.
std::string make_ply(bool ascii, uint32_t deg, const std::vector<std::vector<float>>& rows, bool extra = true) {
  const uint32_t K = (deg + 1) * (deg + 1);
  std::vector<std::string> props = {"x", "y", "z"};
  if (extra) props.push_back("filter_3D");
  for (int k = 0; k < 3; ++k) props.push_back("f_dc_" + std::to_string(k));
  for (uint32_t k = 0; k < 3 * (K - 1); ++k) props.push_back("f_rest_" + std::to_string(k));
  props.push_back("opacity");
  for (int k = 0; k < 3; ++k) props.push_back("scale_" + std::to_string(k));
  for (int k = 0; k < 4; ++k) props.push_back("rot_" + std::to_string(k));
  std::ostringstream h;
  h << "ply\nformat " << (ascii ? "ascii" : "binary_little_endian") << " 1.0\ncomment test\nelement vertex "
    << rows.size() << "\n";
  for (const auto& p : props) h << "property float " << p << "\n";
  h << "end_header\n";
  std::string out = h.str();
  for (const auto& r : rows) {
    REQUIRE(r.size() == props.size());
    for (float v : r) {
      if (ascii) {
        std::ostringstream s;
        s.precision(9);
        s << v << " ";
        out += s.str();
      } else {
        char b[4];
        std::memcpy(b, &v, 4);
        out.append(b, 4);
      }
    }
    if (ascii) out += "\n";
  }
  return out;
}

std::vector<float> make_row(uint32_t deg, float seed, bool extra = true) {
  const uint32_t K = (deg + 1) * (deg + 1);
  std::vector<float> r = {1.0f + seed, 2.0f, -3.0f};
  if (extra) r.push_back(7.0f);
  for (uint32_t k = 0; k < 3 * K; ++k) r.push_back(0.01f * static_cast<float>(k) + seed);
  r.push_back(0.5f);                                // opacity logit
  r.insert(r.end(), {-1.0f, 0.0f, 1.0f});           // log scales
  r.insert(r.end(), {2.0f, 0.0f, 0.0f, 0.0f});      // |q| = 2 -> (1, 0, 0, 0)
  return r;
}

}  // namespace

TEST_CASE("splat ply: every SH degree, binary and ascii, activations and channel-major f_rest") {
  for (bool ascii : {false, true})
    for (uint32_t deg = 0; deg <= 3; ++deg) {
      CAPTURE(ascii);
      CAPTURE(deg);
      const std::string bytes = make_ply(ascii, deg, {make_row(deg, 0.0f), make_row(deg, 1.0f)}) + "trailing junk";
      const auto c = splat::gaussians_from_ply_bytes(bytes, "t.ply");
      REQUIRE(c.size() == 2);
      CHECK(c.sh_degree == deg);
      CHECK(c.positions[1].x == doctest::Approx(2.0));
      CHECK(c.opacities[0] == doctest::Approx(1.0 / (1.0 + std::exp(-0.5))));
      CHECK(c.scales[0].x == doctest::Approx(std::exp(-1.0)));
      CHECK(c.scales[0].z == doctest::Approx(std::exp(1.0)));
      CHECK(c.rotations[0].x == doctest::Approx(1.0));  // w
      const uint32_t K = c.sh_coeffs();
      // file: f_dc_0..2 = 0.00, 0.01, 0.02; f_rest_j = 0.01·(3 + j): channel c coefficient k is rest c·(K−1) + k − 1.
      for (uint32_t ch = 0; ch < 3; ++ch) {
        CHECK(c.sh[ch] == doctest::Approx(0.01 * ch));
        for (uint32_t k = 1; k < K; ++k)
          CHECK(c.sh[k * 3 + ch] == doctest::Approx(0.01 * (3 + ch * (K - 1) + k - 1)));
      }
      // write -> read round trip
      const auto back = splat::gaussians_from_ply_bytes(splat::gaussians_to_ply_bytes(c), "rt.ply");
      REQUIRE(back.size() == c.size());
      CHECK(back.sh_degree == deg);
      for (size_t i = 0; i < c.size(); ++i) {
        CHECK(back.positions[i].x == doctest::Approx(c.positions[i].x));
        CHECK(back.opacities[i] == doctest::Approx(c.opacities[i]).epsilon(1e-5));
        CHECK(back.scales[i].y == doctest::Approx(c.scales[i].y).epsilon(1e-5));
      }
      CHECK(back.sh == c.sh);
    }
}

TEST_CASE("splat ply: NaN, Inf and zero quaternions are rejected naming the file and vertex") {
  auto expect_error = [](std::string bytes, const char* part) {
    try {
      (void)splat::gaussians_from_ply_bytes(bytes, "bad.ply");
      FAIL("no error");
    } catch (const scene::InputError& e) {
      const std::string m = e.what();
      CAPTURE(m);
      CHECK(m.find("bad.ply: vertex 1") == 0);
      CHECK(m.find(part) != std::string::npos);
      CHECK(m.find('\n') == std::string::npos);
    }
  };
  for (bool ascii : {false, true}) {
    auto r = make_row(1, 1.0f);
    r[0] = std::nanf("");
    expect_error(make_ply(ascii, 1, {make_row(1, 0.0f), r}), "'x' is NaN");
    r = make_row(1, 1.0f);
    r[r.size() - 5] = INFINITY;  // scale_2
    expect_error(make_ply(ascii, 1, {make_row(1, 0.0f), r}), "'scale_2' is infinite");
    r = make_row(1, 1.0f);
    for (size_t k = r.size() - 4; k < r.size(); ++k) r[k] = 0.0f;
    expect_error(make_ply(ascii, 1, {make_row(1, 0.0f), r}), "zero quaternion");
    r = make_row(1, 1.0f);
    r[r.size() - 6] = 200.0f;  // scale_1 = exp(200) overflows float
    expect_error(make_ply(ascii, 1, {make_row(1, 0.0f), r}), "overflows");
  }
  // a missing property and a bad f_rest count
  CHECK_THROWS_AS(splat::gaussians_from_ply_bytes("ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nend_header\n",
                                                  "m.ply"),
                  scene::InputError);
}

TEST_CASE("splat ply: the real 3DGS file (SH3, trailing bytes)") {
  const std::string dir = test::test_data_dir();
  const std::string path = dir + "/splats/pc_short.ply";
  if (dir.empty() || !std::filesystem::exists(path)) {
    MESSAGE("skipped: " << path << " not found");
    return;
  }
  const auto c = splat::read_gaussians_ply(path);
  CHECK(c.size() == 100);
  CHECK(c.sh_degree == 3);
  for (size_t i = 0; i < c.size(); ++i) {
    CHECK(std::fabs(glm::length(glm::dvec4(c.rotations[i])) - 1.0) < 1e-6);
    CHECK(c.opacities[i] > 0.0f);
    CHECK(c.opacities[i] < 1.0f);
  }
  const auto s = splat::summarize(c);
  MESSAGE("pc_short.ply: centroid " << s.centroid.x << " " << s.centroid.y << " " << s.centroid.z << ", extent "
                                    << (s.max - s.min).x << " " << (s.max - s.min).y << " " << (s.max - s.min).z
                                    << ", scale median " << s.scale_median);
  const auto back = splat::gaussians_from_ply_bytes(splat::gaussians_to_ply_bytes(c), "rt.ply");
  CHECK(back.sh == c.sh);
}

// The CPU rasteriser (engine/scene/raster.h) and the PNG writers
// (engine/scene/png_write.h): coverage integrals against analytic areas,
// compositing values, text, polyline helpers, and PNG bytes decoded by
// stb_image.
#include <doctest/doctest.h>

#include "scene/atomic_file.h"
#include "scene/png_write.h"
#include "scene/raster.h"

#include "test_stb_image.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <numbers>
#include <random>
#include <stdexcept>

using namespace icube::scene;

namespace {

double polygon_area(const std::vector<glm::dvec2>& ring) {
  double a = 0.0;
  for (size_t i = 0; i < ring.size(); ++i) {
    const glm::dvec2 p = ring[i], q = ring[(i + 1) % ring.size()];
    a += p.x * q.y - q.x * p.y;
  }
  return std::abs(a) * 0.5;
}

std::vector<glm::dvec2> regular_polygon(glm::dvec2 c, double r, int n, bool clockwise = false) {
  std::vector<glm::dvec2> ring;
  for (int i = 0; i < n; ++i) {
    const double a = (clockwise ? -1.0 : 1.0) * 2.0 * std::numbers::pi * i / n;
    ring.push_back(c + r * glm::dvec2(std::cos(a), std::sin(a)));
  }
  return ring;
}

double polyline_length(const std::vector<glm::dvec2>& p) {
  double len = 0.0;
  for (size_t i = 1; i < p.size(); ++i) len += glm::length(p[i] - p[i - 1]);
  return len;
}

uint32_t be32(const std::string& s, size_t at) {
  return (uint32_t(uint8_t(s[at])) << 24) | (uint32_t(uint8_t(s[at + 1])) << 16) | (uint32_t(uint8_t(s[at + 2])) << 8) |
         uint32_t(uint8_t(s[at + 3]));
}

}  // namespace

TEST_CASE("raster: a stroke's cross-section integrates to its width, anti-aliased at the edges") {
  CoverageMask m(300, 80);
  m.stroke_segment({50.3, 40.2}, {250.3, 40.2}, 3.0);
  // Every column away from the caps sums to the width exactly (unit ramps either side).
  for (int x : {80, 150, 201}) {
    double column = 0.0;
    int partial = 0;
    for (int y = 0; y < m.height(); ++y) {
      column += static_cast<double>(m.at(x, y));
      partial += m.at(x, y) > 0.0f && m.at(x, y) < 1.0f;
    }
    CHECK(column == doctest::Approx(3.0).epsilon(1e-6));
    CHECK(partial == 2);  // one soft pixel each side
  }
  CHECK(m.at(150, 40) == 1.0f);
  // Whole stroke: length · width + round caps (pi (w²/4 + 1/12) for the ramped disc).
  const double expected = 200.0 * 3.0 + std::numbers::pi * (2.25 + 1.0 / 12.0);
  CHECK(m.total() == doctest::Approx(expected).epsilon(0.002));
}

TEST_CASE("raster: stroke coverage does not depend on direction, and thin strokes keep their area") {
  CoverageMask diag(300, 300);
  const double len = 200.0;
  const glm::dvec2 a{40.7, 30.1}, d{std::cos(0.61), std::sin(0.61)};
  diag.stroke_segment(a, a + len * d, 3.0);
  CHECK(diag.total() == doctest::Approx(len * 3.0 + std::numbers::pi * (2.25 + 1.0 / 12.0)).epsilon(0.003));

  CoverageMask thin(300, 60);
  thin.stroke_segment({20.0, 30.5}, {220.0, 30.5}, 0.4);  // sub-pixel width: faint, not lost
  CHECK(thin.total() == doctest::Approx(200.0 * 0.4 + 0.4 * std::numbers::pi / 3.0).epsilon(0.003));
  CHECK(static_cast<double>(thin.at(100, 30)) == doctest::Approx(0.4));
}

TEST_CASE("raster: a polyline blends once, so translucent joints are not darker") {
  Canvas c(100, 100, {0, 0, 0, 255});
  c.stroke_polyline({{10, 50}, {50, 50}, {50, 10}}, 5.0, {255, 255, 255, 128});
  // Pixels in the middle of a segment and at the joint get the same single blend.
  CHECK(c.pixel(30, 50) == c.pixel(50, 50));
  CHECK(c.pixel(30, 50).r == 128);
}

TEST_CASE("raster: polygon fill area is within 1% of the analytic area") {
  CoverageMask m(400, 300);
  const auto circle = regular_polygon({180.37, 140.61}, 60.0, 128);
  m.fill_polygon(circle);
  CHECK(m.total() == doctest::Approx(polygon_area(circle)).epsilon(0.01));
  m.clear();
  CHECK(m.total() == 0.0);

  // A long thin rotated rectangle (2 px wide): the hard case for scanlines.
  const glm::dvec2 u{std::cos(0.3), std::sin(0.3)}, v{-u.y, u.x}, o{30.2, 40.9};
  const std::vector<glm::dvec2> rect{o, o + 300.0 * u, o + 300.0 * u + 2.0 * v, o + 2.0 * v};
  m.fill_polygon(rect);
  CHECK(m.total() == doctest::Approx(600.0).epsilon(0.01));
  m.clear();

  // A triangle with fractional vertices.
  const std::vector<glm::dvec2> tri{{10.25, 10.75}, {390.5, 120.125}, {60.875, 290.5}};
  m.fill_polygon(tri);
  CHECK(m.total() == doctest::Approx(polygon_area(tri)).epsilon(0.01));
}

TEST_CASE("raster: polygon fill uses nonzero winding and clips to the image") {
  CoverageMask m(200, 200);
  // Outer square with a hole of opposite winding: area = outer - inner.
  const std::vector<glm::dvec2> outer{{20, 20}, {180, 20}, {180, 180}, {20, 180}};
  const std::vector<glm::dvec2> hole{{60, 60}, {60, 140}, {140, 140}, {140, 60}};
  m.fill_polygons({outer, hole});
  CHECK(m.total() == doctest::Approx(160.0 * 160.0 - 80.0 * 80.0).epsilon(1e-6));
  CHECK(m.at(100, 100) == 0.0f);
  CHECK(m.at(40, 40) == 1.0f);
  m.clear();
  // The same winding twice (overlap) is still covered once.
  m.fill_polygons({outer, {{60, 60}, {140, 60}, {140, 140}, {60, 140}}});
  CHECK(m.total() == doctest::Approx(160.0 * 160.0).epsilon(1e-6));
  m.clear();
  // Half outside the image: only the inside part counts.
  m.fill_polygon({{-100, 50}, {100, 50}, {100, 150}, {-100, 150}});
  CHECK(m.total() == doctest::Approx(100.0 * 100.0).epsilon(1e-6));
}

TEST_CASE("raster: shapes reaching far outside the image are clipped without overflow") {
  CoverageMask m(100, 20);
  m.stroke_segment({-1e15, 10.0}, {1e15, 10.0}, 2.0);
  CHECK(m.total() == doctest::Approx(100.0 * 2.0).epsilon(1e-9));
  m.clear();
  m.fill_polygon({{-1e12, -1e12}, {1e12, -1e12}, {0.0, 1e12}});
  CHECK(m.total() == doctest::Approx(100.0 * 20.0).epsilon(1e-9));
  m.clear();
  m.fill_circle({5e11, 5e11}, 10.0);
  m.fill_rect(-1e300, -1e300, 1e300, 1e300);
  CHECK(m.total() == doctest::Approx(100.0 * 20.0).epsilon(1e-9));
}

TEST_CASE("raster: circles and rectangles cover their area") {
  CoverageMask m(200, 200);
  m.fill_circle({100.3, 99.6}, 40.0);
  CHECK(m.total() == doctest::Approx(std::numbers::pi * 1600.0).epsilon(0.005));
  m.clear();
  m.fill_rect(10.25, 20.5, 30.75, 40.0);
  CHECK(m.total() == doctest::Approx(20.5 * 19.5).epsilon(1e-6));
  CHECK(static_cast<double>(m.at(10, 25)) == doctest::Approx(0.75));
}

TEST_CASE("raster: stripes keep their duty cycle") {
  CoverageMask m(200, 200);
  m.fill_rect(0, 0, 200, 200);
  m.modulate_stripes({0.0, 0.0}, {1.0, 0.0}, 10.0, 0.5);
  CHECK(m.total() == doctest::Approx(200.0 * 200.0 * 0.5).epsilon(0.01));
  CHECK(m.at(2, 50) == 1.0f);  // inside a stripe
  CHECK(m.at(7, 50) == 0.0f);  // between stripes
}

TEST_CASE("raster: compositing is source-over with straight alpha") {
  Canvas c(4, 1, {0, 0, 0, 255});
  c.blend(0, 0, {255, 255, 255, 255}, 0.5);
  c.blend(1, 0, {200, 100, 50, 255}, 1.0);
  c.blend(2, 0, {255, 0, 0, 51}, 1.0);  // 20% red
  c.blend(9, 0, {255, 0, 0, 255}, 1.0); // outside: ignored
  CHECK(c.pixel(0, 0) == Rgba{128, 128, 128, 255});
  CHECK(c.pixel(1, 0) == Rgba{200, 100, 50, 255});
  CHECK(c.pixel(2, 0) == Rgba{51, 0, 0, 255});
  CHECK(c.pixel(3, 0) == Rgba{0, 0, 0, 255});
  CHECK(with_opacity({10, 20, 30, 200}, 0.5) == Rgba{10, 20, 30, 100});
}

TEST_CASE("raster: text draws pixels inside its measured box only") {
  Canvas c(300, 80, {0, 0, 0, 255});
  const std::string text = "Scale 50 m";
  const int x = 20, y = 30, scale = 2;
  c.draw_text(x, y, text, {255, 255, 255, 255}, scale);
  const int w = text_width(text, scale), h = text_height(text, scale);
  CHECK(w == 2 * text_width(text, 1));
  CHECK(h == 24);
  int inside = 0, outside = 0;
  for (int py = 0; py < c.height(); ++py)
    for (int px = 0; px < c.width(); ++px) {
      if (c.pixel(px, py).r == 0) continue;
      (px >= x && px < x + w && py >= y && py < y + h ? inside : outside) += 1;
    }
  CHECK(inside > 100);
  CHECK(outside == 0);
  // Non-ASCII bytes are drawn as '?' instead of indexing past the font table.
  CHECK(text_width("\xc3\xa9", 1) == text_width("??", 1));
}

TEST_CASE("raster: dash_polyline cuts exact dashes across vertices") {
  const std::vector<glm::dvec2> line{{0, 0}, {37, 0}, {100, 0}};
  const auto dashes = dash_polyline(line, 10.0, 5.0);
  REQUIRE(dashes.size() == 7);  // 0-10, 15-25, ..., 90-100
  for (size_t i = 0; i < dashes.size(); ++i) {
    CHECK(polyline_length(dashes[i]) == doctest::Approx(10.0));
    CHECK(dashes[i].front().x == doctest::Approx(15.0 * static_cast<double>(i)));
  }
  CHECK(dashes[2].size() == 3);  // 30-40 passes the vertex at 37
}

TEST_CASE("raster: offset_polyline moves along (-dy, dx) with limited miters") {
  const auto straight = offset_polyline({{0, 0}, {10, 0}, {20, 0}}, 2.0);
  for (const glm::dvec2& p : straight) CHECK(p.y == doctest::Approx(2.0));
  const auto corner = offset_polyline({{0, 0}, {10, 0}, {10, 10}}, 1.0);
  CHECK(corner[1].x == doctest::Approx(9.0));  // inside of the right-angle turn
  CHECK(corner[1].y == doctest::Approx(1.0));
  CHECK(thin_polyline({{0, 0}, {0.1, 0}, {0.2, 0}, {1.0, 0}, {1.05, 0}}, 0.5).size() == 3);
}

TEST_CASE("png: RGBA8 and RGB8 encode and decode exactly") {
  std::mt19937 rng(12345);
  const int w = 37, h = 23;
  for (int channels : {3, 4}) {
    CAPTURE(channels);
    std::vector<uint8_t> px(static_cast<size_t>(w * h * channels));
    for (auto& v : px) v = static_cast<uint8_t>(rng());
    const std::string png = encode_png(px.data(), w, h, channels);
    REQUIRE(png.substr(0, 8) == std::string("\x89PNG\r\n\x1a\n", 8));
    int dw = 0, dh = 0, dc = 0;
    uint8_t* got = stbi_load_from_memory(reinterpret_cast<const stbi_uc*>(png.data()), static_cast<int>(png.size()), &dw,
                                         &dh, &dc, channels);
    REQUIRE(got);
    CHECK(dw == w);
    CHECK(dh == h);
    CHECK(dc == channels);
    CHECK(std::vector<uint8_t>(got, got + px.size()) == px);
    stbi_image_free(got);
  }
  CHECK_THROWS_AS(encode_png(nullptr, 0, 5, 3), std::invalid_argument);
  CHECK_THROWS_AS(encode_png(nullptr, 5, 5, 5), std::invalid_argument);
}

TEST_CASE("png: 16-bit grey round-trips through stb_image") {
  std::mt19937 rng(777);
  const int w = 61, h = 17;
  std::vector<uint16_t> px(static_cast<size_t>(w * h));
  for (size_t i = 0; i < px.size(); ++i) px[i] = static_cast<uint16_t>(i % 5 == 0 ? i * 97 : rng());  // smooth + noisy
  px[0] = 0, px[1] = 65535;
  const std::string png = encode_png_gray16(px.data(), w, h);
  const auto* bytes = reinterpret_cast<const stbi_uc*>(png.data());
  CHECK(stbi_is_16_bit_from_memory(bytes, static_cast<int>(png.size())) == 1);
  int dw = 0, dh = 0, dc = 0;
  uint16_t* got = stbi_load_16_from_memory(bytes, static_cast<int>(png.size()), &dw, &dh, &dc, 1);
  REQUIRE(got);
  CHECK(dw == w);
  CHECK(dh == h);
  CHECK(dc == 1);
  CHECK(std::vector<uint16_t>(got, got + px.size()) == px);  // stb returns host order
  stbi_image_free(got);
}

TEST_CASE("png: 16-bit samples are stored big-endian (formats.md §10)") {
  const uint16_t px[2] = {0x1234, 0xABCD};
  const std::string png = encode_png_gray16(px, 2, 1);
  // IHDR right after the signature: length 13, width 2, height 1, depth 16, colour type 0.
  REQUIRE(png.size() > 33);
  CHECK(be32(png, 8) == 13);
  CHECK(png.substr(12, 4) == "IHDR");
  CHECK(be32(png, 16) == 2);
  CHECK(be32(png, 20) == 1);
  CHECK(uint8_t(png[24]) == 16);
  CHECK(uint8_t(png[25]) == 0);
  // IEND's CRC is the same in every PNG.
  CHECK(be32(png, png.size() - 4) == 0xAE426082u);
  // Inflate IDAT and undo the row filter (row 0: the prior row is zero).
  const size_t idat_len = be32(png, 33);
  REQUIRE(png.substr(37, 4) == "IDAT");
  int raw_len = 0;
  char* raw = stbi_zlib_decode_malloc(png.data() + 41, static_cast<int>(idat_len), &raw_len);
  REQUIRE(raw);
  REQUIRE(raw_len == 5);
  const auto* r = reinterpret_cast<const uint8_t*>(raw);
  uint8_t row[4];
  for (int i = 0; i < 4; ++i) {
    const int left = i >= 2 ? row[i - 2] : 0;
    const int pred = r[0] == 1 || r[0] == 4 ? left : (r[0] == 3 ? left / 2 : 0);
    row[i] = static_cast<uint8_t>(r[1 + i] + pred);
  }
  STBI_FREE(raw);
  CHECK(row[0] == 0x12);
  CHECK(row[1] == 0x34);
  CHECK(row[2] == 0xAB);
  CHECK(row[3] == 0xCD);
}

TEST_CASE("png: write_png writes the encoded bytes atomically and names the path on failure") {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "icube_test_png";
  std::filesystem::create_directories(dir);
  const std::string path = (dir / "tiny.png").string();
  const uint8_t px[12] = {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12};
  write_png(path, px, 2, 2, 3);
  CHECK(read_file(path) == encode_png(px, 2, 2, 3));
  std::filesystem::remove_all(dir);
  try {
    write_png((dir / "no" / "such" / "dir.png").string(), px, 2, 2, 3);
    FAIL("expected an error");
  } catch (const std::runtime_error& e) {
    CHECK(std::string(e.what()).find("dir.png") != std::string::npos);
  }
}

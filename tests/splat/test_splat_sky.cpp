// Sky models of the splatting rasterizer (splat/sky.h): z-up gradient and
// equirect image (incl. its seam and PNG loading), GPU against the CPU
// reference through the stage-by-stage comparison, and hand-checked directions.
#include <doctest/doctest.h>

#include "gpu_test_context.h"
#include "scene/png_write.h"
#include "splat/sky.h"
#include "splat_compare.h"

#include <cmath>
#include <filesystem>
#include <memory>
#include <vector>

using namespace icube;
using namespace icube::test;
using splat::SplatOptions;

namespace {
// 64 × 32 equirect test image: smooth in longitude and latitude plus a few sharp texels.
std::shared_ptr<splat::SkyImage> test_sky_image() {
  auto img = std::make_shared<splat::SkyImage>();
  img->width = 64;
  img->height = 32;
  img->rgba.resize(64 * 32 * 4);
  for (uint32_t y = 0; y < 32; ++y)
    for (uint32_t x = 0; x < 64; ++x) {
      uint8_t* t = &img->rgba[(y * 64 + x) * 4];
      t[0] = static_cast<uint8_t>(x * 4);
      t[1] = static_cast<uint8_t>(y * 8);
      t[2] = static_cast<uint8_t>((x * 37 + y * 11) % 256);
      t[3] = 255;
    }
  return img;
}
}  // namespace

TEST_CASE("splat sky: gradient and equirect, GPU vs CPU reference, and hand-checked directions") {
  Renderer R;
  const auto cloud = test::random_cloud(11, 300, 2, {0.0, 0.0, 0.0}, 1.0);
  // Looking along +x from the origin side, horizontal: the principal ray is (1, 0, 0).
  const uint32_t W = 97, H = 61;
  auto cam = test::look_at_camera({-6.0, 0.0, 0.0}, {0.0, 0.0, 0.0}, W, H, 40.0);
  cam.K.cx = 48.0;
  cam.K.cy = 30.0;
  const auto image = test_sky_image();
  SplatOptions o;
  o.pixels = render::PixelConvention::Integer;
  o.background = {0.9f, 0.1f, 0.1f};

  SUBCASE("gradient") {
    splat::SkyGradient g;
    g.zenith = {0.0f, 0.0f, 1.0f};
    g.horizon = {1.0f, 1.0f, 1.0f};
    g.ground = {0.0f, 1.0f, 0.0f};
    o.sky = splat::sky_gradient(g);
    report("sky gradient", compare(R.r, cloud, cam, o));
    // Hand check (no Gaussians): the principal ray is horizontal -> horizon; top row looks up.
    splat::GaussianCloud empty;
    const auto img = R.r.render(R.r.upload(empty), cam, o);
    const size_t centre = size_t{30} * W + 48;
    CHECK(img.rgba[4 * centre + 0] == doctest::Approx(1.0).epsilon(1e-5));
    CHECK(img.rgba[4 * centre + 1] == doctest::Approx(1.0).epsilon(1e-5));
    const glm::dvec3 d0 = render::camera_ray(cam, 48, 0, render::PixelConvention::Integer).dir;
    REQUIRE(d0.z > 0.3);  // z-up world: the top row looks up
    CHECK(img.rgba[4 * 48 + 0] == doctest::Approx(1.0 - d0.z).epsilon(1e-4));
    CHECK(img.rgba[4 * 48 + 2] == doctest::Approx(1.0).epsilon(1e-5));
    const size_t bottom = size_t{H - 1} * W + 48;
    const glm::dvec3 d1 = render::camera_ray(cam, 48, H - 1, render::PixelConvention::Integer).dir;
    CHECK(img.rgba[4 * bottom + 0] == doctest::Approx(1.0 + d1.z).epsilon(1e-4));  // d1.z < 0: towards ground
    CHECK(img.rgba[4 * bottom + 1] == doctest::Approx(1.0).epsilon(1e-5));
    // The sky is weighted by the final transmittance: T = 1 - alpha.
    const auto cimg = splat::render_cpu(cloud, cam, o);
    size_t covered = 0;
    for (size_t p = 0; p < size_t{W} * H; ++p) covered += cimg.rgba[4 * p + 3] > 0.5f;
    CHECK(covered > 0);
  }
  SUBCASE("equirect") {
    o.sky = splat::sky_equirect(image);
    report("sky equirect", compare(R.r, cloud, cam, o));
    splat::GaussianCloud empty;
    const auto img = R.r.render(R.r.upload(empty), cam, o);
    // +x, horizontal: s = 0.5·W, t = 0.5·H -> the mean of texels (31..32, 15..16).
    const size_t centre = size_t{30} * W + 48;
    auto tex = [&](int x, int y, int c) { return image->rgba[(size_t(y) * 64 + size_t(x)) * 4 + size_t(c)] / 255.0; };
    for (int c = 0; c < 3; ++c) {
      const double want = 0.25 * (tex(31, 15, c) + tex(32, 15, c) + tex(31, 16, c) + tex(32, 16, c));
      CHECK(img.rgba[4 * centre + size_t(c)] == doctest::Approx(want).epsilon(2e-3));
    }
    // Looking along +y (λ = +π/2): s = 0.25·W, so the red channel (4·x / 255) is ~4·15.5/255.
    auto cam_y = test::look_at_camera({0.0, -6.0, 0.0}, {0.0, 0.0, 0.0}, W, H, 40.0);
    cam_y.K.cx = 48.0;
    cam_y.K.cy = 30.0;
    const auto img_y = R.r.render(R.r.upload(empty), cam_y, o);
    CHECK(img_y.rgba[4 * centre] == doctest::Approx(4.0 * 15.5 / 255.0).epsilon(2e-3));
    // Image seam (λ = ±π, looking along −x): wraps between columns 63 and 0.
    auto cam_mx = test::look_at_camera({6.0, 0.0, 0.0}, {0.0, 0.0, 0.0}, W, H, 40.0);
    cam_mx.K.cx = 48.0;
    cam_mx.K.cy = 30.0;
    report("sky equirect seam", compare(R.r, cloud, cam_mx, o));
  }
  SUBCASE("PNG round trip and the CLI spec") {
    const std::string path = (std::filesystem::temp_directory_path() / "icube_test_sky.png").string();
    std::vector<uint8_t> rgb(64 * 32 * 3);
    for (size_t i = 0; i < 64 * 32; ++i)
      for (int c = 0; c < 3; ++c) rgb[3 * i + size_t(c)] = image->rgba[4 * i + size_t(c)];
    scene::write_png(path, rgb.data(), 64, 32, 3);
    const splat::SkyModel s = splat::parse_sky(path);
    REQUIRE(s.kind == splat::SkyKind::Equirect);
    CHECK(s.image->width == 64);
    CHECK(s.image->height == 32);
    CHECK(test::equal_report(s.image->rgba, image->rgba, "decoded sky texels"));
    std::filesystem::remove(path);
    CHECK(splat::parse_sky("gradient").kind == splat::SkyKind::Gradient);
    CHECK(splat::parse_sky("background").kind == splat::SkyKind::Background);
    CHECK_THROWS_WITH_AS(splat::parse_sky("/nonexistent/sky.png"),
                         doctest::Contains("/nonexistent/sky.png"), std::runtime_error);
    splat::SkyModel bad;
    bad.kind = splat::SkyKind::Equirect;
    CHECK_THROWS_AS(splat::validate_sky(bad), std::invalid_argument);
  }
}

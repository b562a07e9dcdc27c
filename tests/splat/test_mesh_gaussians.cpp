// splat::mesh_surface_gaussians: the tiling (counts, positions on the
// triangle, orientation along the normal, σ), the paint classes and baked
// shading, degenerate input, the budget, and coverage: the CPU splatting
// reference renders the discs of a square as an opaque square of its colour.
#include <doctest/doctest.h>

#include "splat/mesh_gaussians.h"
#include "splat/rasterizer_cpu.h"
#include "splat/test_splat_util.h"
#include "world/car_mesh.h"
#include "world/mesh_voxelize.h"

#include <glm/gtc/quaternion.hpp>

#include <cmath>
#include <stdexcept>

using namespace icube;

namespace {

// A unit square in z = h: two triangles, normal +z.
world::TriangleMesh square(double h, double size = 1.0) {
  world::TriangleMesh m;
  m.positions = {{0.0, 0.0, h}, {size, 0.0, h}, {size, size, h}, {0.0, size, h}};
  m.triangles = {{0, 1, 2}, {0, 2, 3}};
  return m;
}

glm::vec3 colour(const splat::GaussianCloud& c, size_t i) {
  glm::vec3 rgb;
  for (int k = 0; k < 3; ++k) rgb[k] = static_cast<float>(static_cast<double>(c.sh[3 * i + size_t(k)]) * splat::kShC0 + 0.5);
  return rgb;
}

}  // namespace

TEST_CASE("mesh Gaussians: a square tiled by m^2 discs per triangle, on the plane, facing its normal") {
  splat::MeshGaussianOptions o;
  o.spacing = 0.1;
  const splat::GaussianCloud c = splat::mesh_surface_gaussians(square(0.0), {}, o);
  // the longest edge is the diagonal, sqrt(2): m = ceil(14.14) = 15 per triangle
  CHECK(c.size() == 2 * 15 * 15);
  CHECK(c.sh_degree == 0);
  CHECK_NOTHROW(c.validate());
  const float sigma = static_cast<float>(0.5 * std::sqrt(2.0) / 15.0);
  for (size_t i = 0; i < c.size(); ++i) {
    const glm::dvec3 p = c.positions[i];
    CHECK(p.z == 0.0);
    CHECK(p.x > 0.0);
    CHECK(p.x < 1.0);
    CHECK(p.y > 0.0);
    CHECK(p.y < 1.0);
    CHECK(c.scales[i].x == doctest::Approx(sigma));
    CHECK(c.scales[i].y == doctest::Approx(sigma));
    CHECK(c.scales[i].z == doctest::Approx(o.normal_sigma));
    const glm::vec4 q = c.rotations[i];
    const glm::dmat3 R = glm::mat3_cast(glm::dquat(q.x, q.y, q.z, q.w));
    CHECK(glm::length(R[2] - glm::dvec3(0.0, 0.0, 1.0)) < 1e-6);  // the thin axis along the normal
  }
  // the discs' centroids spread evenly: every 0.1 m cell of the square holds some
  int cells[10][10] = {};
  for (const glm::dvec3& p : c.positions) ++cells[int(p.y * 10.0)][int(p.x * 10.0)];
  int empty = 0;
  for (auto& row : cells)
    for (int n : row) empty += n == 0;
  CHECK(empty == 0);
}

TEST_CASE("mesh Gaussians: paint classes by height and normal, shading baked in") {
  splat::MeshPaint paint;
  paint.ambient = 0.5f;
  paint.sun = {0.0, 0.0, 2.0};  // straight down: n·sun = 1 on a floor, 0 on a wall
  splat::MeshGaussianOptions o;
  o.spacing = 0.25;
  world::TriangleMesh m = square(0.0);  // the lowest point: z = 0, so this floor is "tire"
  const size_t floor_tris = m.triangles.size();
  // a roof at 1.5 m (above the belt, but horizontal: body) and a wall from 1.2 to 1.4 m (glass)
  const world::TriangleMesh roof = square(1.5);
  for (const glm::uvec3& t : roof.triangles) m.triangles.push_back(t + glm::uvec3(m.positions.size()));
  m.positions.insert(m.positions.end(), roof.positions.begin(), roof.positions.end());
  const uint32_t w0 = static_cast<uint32_t>(m.positions.size());
  m.positions.insert(m.positions.end(), {{0.0, 0.0, 1.2}, {1.0, 0.0, 1.2}, {1.0, 0.0, 1.4}, {0.0, 0.0, 1.4}});
  m.triangles.push_back({w0, w0 + 1, w0 + 2});
  m.triangles.push_back({w0, w0 + 2, w0 + 3});
  CHECK(floor_tris == 2);
  const splat::GaussianCloud c = splat::mesh_surface_gaussians(m, paint, o);
  size_t tire = 0, body = 0, glass = 0;
  for (size_t i = 0; i < c.size(); ++i) {
    const glm::vec3 rgb = colour(c, i);
    const double z = c.positions[i].z;
    if (z < 0.1) {
      CHECK(glm::length(rgb - paint.tire) < 1e-5f);  // lit fully from above
      ++tire;
    } else if (z > 1.45) {
      CHECK(glm::length(rgb - paint.body) < 1e-5f);
      ++body;
    } else {
      CHECK(glm::length(rgb - 0.5f * paint.glass) < 1e-5f);  // a wall: ambient only
      ++glass;
    }
  }
  CHECK(tire > 0);
  CHECK(body > 0);
  CHECK(glass > 0);
  CHECK(tire + body + glass == c.size());
}

TEST_CASE("mesh Gaussians: degenerate triangles give nothing; bad options and the budget throw") {
  world::TriangleMesh m;
  m.positions = {{0.0, 0.0, 0.0}, {1.0, 0.0, 0.0}, {2.0, 0.0, 0.0}};
  m.triangles = {{0, 1, 2}, {0, 0, 0}};  // collinear, and one point
  CHECK(splat::mesh_surface_gaussians(m).size() == 0);
  CHECK(splat::mesh_surface_gaussians(world::TriangleMesh{}).size() == 0);
  splat::MeshGaussianOptions bad;
  bad.spacing = 0.0;
  CHECK_THROWS_AS(splat::mesh_surface_gaussians(square(0.0), {}, bad), std::invalid_argument);
  bad.spacing = std::nan("");
  CHECK_THROWS_AS(splat::mesh_surface_gaussians(square(0.0), {}, bad), std::invalid_argument);
  splat::MeshGaussianOptions tight;
  tight.spacing = 1e-3;  // 2 x 1415^2 = 4.0 M discs
  tight.max_gaussians = 1'000'000;
  CHECK_THROWS_WITH_AS(splat::mesh_surface_gaussians(square(0.0), {}, tight), doctest::Contains("more than 1000000"),
                       std::invalid_argument);
}

TEST_CASE("mesh Gaussians: the CPU splatting reference draws a square's discs as an opaque square of its colour") {
  splat::MeshPaint paint;
  paint.sun = {0.0, 0.0, 1.0};
  paint.tire_height = -1.0;  // the square is the mesh's lowest point: body, not tire
  const splat::GaussianCloud c = splat::mesh_surface_gaussians(square(2.0, 2.0), paint);  // 0.05 m spacing
  // 1 m above the square's centre, looking down, f = 100 px: the 2 m square spans pixels 48 ± 100,
  // beyond the 96-pixel view, so every pixel sees it.
  const render::Camera cam = test::look_at_camera(glm::dvec3(1.0, 1.0, 3.0), glm::dvec3(1.0, 1.0, 2.0), 96, 96, 100.0);
  splat::SplatOptions so;
  const splat::SplatImage img = splat::render_cpu(c, cam, so);
  // Each pixel must be opaque and of the body colour lit from above. Head-on, the least covered
  // points between the discs keep alpha 0.9916 (measured): about 2 levels of 255 on white.
  size_t n = 0, bad = 0;
  float worst_alpha = 1.0f, worst_err = 0.0f;
  for (uint32_t v = 0; v < 96; ++v)
    for (uint32_t u = 0; u < 96; ++u) {
      const size_t i = size_t{v} * 96 + u;
      const float alpha = img.rgba[4 * i + 3];
      float err = 0.0f;
      for (int k = 0; k < 3; ++k) err = std::max(err, std::fabs(img.rgba[4 * i + size_t(k)] - paint.body[k]));
      worst_alpha = std::min(worst_alpha, alpha);
      worst_err = std::max(worst_err, err);
      if ((alpha < 0.99f || err > 0.01f * paint.body.r) && bad++ < 5)
        MESSAGE("pixel (" << u << ", " << v << "): alpha " << alpha << ", colour error " << err);
      ++n;
    }
  MESSAGE("square of discs: least alpha " << worst_alpha << ", largest colour error " << worst_err);
  CHECK(n == 96 * 96);
  CHECK(bad == 0);
}

TEST_CASE("mesh Gaussians: the built-in car fitted into a 4.6 x 2.0 x 1.6 m box") {
  const world::TriangleMesh fitted = world::fit_mesh_to_box(world::builtin_car_mesh(), 4.6, 2.0, 1.6);
  const splat::GaussianCloud c = splat::mesh_surface_gaussians(fitted);
  MESSAGE("built-in car: " << fitted.triangles.size() << " triangles, " << c.size() << " Gaussians");
  CHECK(c.size() > 10000);
  CHECK(c.size() < 200000);  // the viewer re-places them every frame its car moves
  splat::MeshPaint paint;
  size_t tire = 0, glass = 0;
  for (size_t i = 0; i < c.size(); ++i) {
    const glm::dvec3 p = c.positions[i];
    CHECK(std::fabs(p.x) <= 2.3 + 1e-9);
    CHECK(std::fabs(p.y) <= 1.0 + 1e-9);
    CHECK(std::fabs(p.z) <= 0.8 + 1e-9);
    const glm::vec3 rgb = colour(c, i);
    tire += rgb.r <= paint.tire.r + 1e-4f && p.z < -0.5;
    glass += rgb.b > rgb.r && p.z > 0.3;  // the dark blue-grey glass above the belt line (1.1 m: z > 0.3)
  }
  CHECK(tire > 500);   // wheels
  CHECK(glass > 500);  // windows
}

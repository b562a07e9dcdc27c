// viewer::GaussianView (the viewer's Gaussian view of a package) on a small
// splat scene written here: the whole-set view equals the host path (the scene
// composed at the frame, uploaded and rasterized, converted to RGBA8 on the
// CPU); the moving object follows the time index; an unchanged view is not
// drawn again; the moving level of detail draws fewer Gaussians; time indices
// past the last frame show the last frame; our own car is drawn at the pose
// given and leaves no trace when it is not.
#include <doctest/doctest.h>

#include "cli_test_util.h"
#include "gaussian_view.h"
#include "gpu_test_context.h"
#include "scene/frames.h"
#include "splat/mesh_gaussians.h"
#include "splat/rasterizer_gpu.h"
#include "splat/splat_rgba8.h"
#include "splat/test_splat_util.h"
#include "world/car_mesh.h"
#include "world/mesh_voxelize.h"

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

using namespace icube;

namespace {

// Largest per-channel difference and the count of differing channels (alpha ignored).
void rgba_diff(const std::vector<uint8_t>& a, const std::vector<uint8_t>& b, int* max_d, size_t* differing) {
  *max_d = 0;
  *differing = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    if (i % 4 == 3) continue;
    const int d = std::abs(int(a[i]) - int(b[i]));
    *max_d = std::max(*max_d, d);
    *differing += d > 0;
  }
}

}  // namespace

TEST_CASE("gaussian view: whole-set view equals the host path; objects follow the time; unchanged views reused") {
  gpu::Context& ctx = test::gpu_context();
  test::TempDir dir("gaussian-view");
  // A 60 m ground layer of Gaussians and a 3 m "car" that drives +x by 2 m per frame over 3 frames.
  splat::GaussianCloud ground = test::random_cloud(41, 30000, 0, glm::dvec3(0.0, 0.0, 0.0), 30.0, -2.0, -0.7);
  for (auto& p : ground.positions) p.z *= 0.01;
  const splat::GaussianCloud car = test::random_cloud(42, 800, 1, glm::dvec3(0.0), 1.2, -2.5, -1.2);
  splat::write_gaussians_ply((dir.path / "static.ply").string(), ground);
  splat::write_gaussians_ply((dir.path / "car.ply").string(), car);
  {
    std::ofstream f(dir.path / "scene.json");
    f << R"({"format": "icube-splat-scene", "version": 1, "static": "static.ply", "frames": 3,
             "objects": [{"id": 10000, "gaussians": "car.ply", "track": [
               {"frame": 0, "position": [4.0, 0.0, 1.0], "yaw": 0.0},
               {"frame": 1, "position": [6.0, 0.0, 1.0], "yaw": 0.3},
               {"frame": 2, "position": [8.0, 0.0, 1.0], "yaw": 0.6}]}]})";
  }
  viewer::GaussianViewOptions o;
  o.chunking.chunk_size = 8.0;
  o.moving.coarse_distance = 6.0;
  viewer::GaussianView view(ctx, (dir.path / "scene.json").string(), "", o);
  CHECK(view.frames() == 3);
  CHECK(view.stats().static_gaussians == ground.size());
  CHECK(view.stats().objects == 1);
  CHECK(view.frame_of(1) == 1);
  CHECK(view.frame_of(99) == 2);

  const render::Camera cam = test::look_at_camera(glm::dvec3(-6.0, 1.5, 3.0), glm::dvec3(8.0, 0.0, 0.5), 173, 97, 120.0);
  const splat::SplatScene sc = splat::read_splat_scene((dir.path / "scene.json").string());
  splat::SplatRendererGpu r(ctx);
  splat::SplatOptions so;
  so.depth = false;
  so.sky = splat::sky_gradient();
  auto host = [&](size_t frame) {
    const splat::SplatImage img = r.render(r.upload(splat::compose_frame(sc, frame)), cam, so);
    const std::vector<uint32_t> words = splat::splat_to_rgba8_cpu(img.rgba);
    std::vector<uint8_t> px(words.size() * 4);
    std::memcpy(px.data(), words.data(), px.size());
    return px;
  };
  std::vector<uint8_t> shown[3];
  for (size_t t = 0; t < 3; ++t) {
    CHECK(view.draw(cam, t, viewer::GaussianDetail::Whole));
    CHECK(view.stats().drawn == ground.size() + car.size());
    shown[t] = view.download_rgba();
    REQUIRE(shown[t].size() == size_t{173} * 97 * 4);
    int max_d = 0;
    size_t differing = 0;
    rgba_diff(shown[t], host(t), &max_d, &differing);
    INFO("frame " << t << ": max difference " << max_d << " levels, " << differing << " channels differ");
    CHECK(max_d <= 1);  // the same Gaussians at another float origin and in chunk order
    CHECK(differing < shown[t].size() / 1000);
  }
  int max_d = 0;
  size_t differing = 0;
  rgba_diff(shown[0], shown[1], &max_d, &differing);
  CHECK(differing > 200);  // the car moved

  // Unchanged: not drawn again, the image stays.
  const size_t renders = view.stats().renders;
  CHECK_FALSE(view.draw(cam, 2, viewer::GaussianDetail::Whole));
  CHECK_FALSE(view.draw(cam, 7, viewer::GaussianDetail::Whole));  // past the end: the last frame
  CHECK(view.stats().renders == renders);
  CHECK(view.download_rgba() == shown[2]);

  // The moving level of detail: fewer Gaussians, culled chunks, the car still there.
  CHECK(view.draw(cam, 2, viewer::GaussianDetail::Moving));
  CHECK(view.stats().drawn < ground.size() / 2);
  CHECK(view.stats().chunks_out > 0);
  CHECK(view.stats().chunks_coarse > 0);
  const std::vector<uint8_t> moving = view.download_rgba();
  rgba_diff(moving, shown[2], &max_d, &differing);
  CHECK(differing > 0);
}

TEST_CASE("gaussian view: our car is drawn at the pose it is given, and a new pose draws the view again") {
  gpu::Context& ctx = test::gpu_context();
  test::TempDir dir("gaussian-view-own");
  splat::GaussianCloud ground = test::random_cloud(43, 5000, 0, glm::dvec3(0.0), 30.0, -2.0, -0.7);
  for (auto& p : ground.positions) p.z *= 0.01;
  splat::write_gaussians_ply((dir.path / "static.ply").string(), ground);
  viewer::GaussianView view(ctx, (dir.path / "static.ply").string(), "");
  const world::TriangleMesh mesh = world::builtin_car_mesh();
  view.set_own_car(mesh, 4.6, 2.0, 1.6);
  const size_t own = view.own_car_gaussians();
  splat::MeshGaussianOptions mo;
  mo.spacing = 0.08;
  CHECK(own == splat::mesh_surface_gaussians(world::fit_mesh_to_box(mesh, 4.6, 2.0, 1.6), {}, mo).size());

  // A chase camera 8 m behind and 3 m above a car at the origin heading +x.
  const render::Camera cam = test::look_at_camera(glm::dvec3(-8.0, 0.0, 3.0), glm::dvec3(0.0, 0.0, 0.8), 160, 90, 110.0);
  scene::BoxState box;
  box.center = {0.0, 0.0, 0.8};
  box.length = 4.6;
  box.width = 2.0;
  box.height = 1.6;
  box.valid = true;
  const glm::dmat4 pose = scene::box_to_world(box);

  CHECK(view.draw(cam, 0, viewer::GaussianDetail::Whole));
  CHECK(view.stats().drawn == ground.size());
  const std::vector<uint8_t> without = view.download_rgba();
  CHECK(view.draw(cam, 0, viewer::GaussianDetail::Whole, &pose));
  CHECK(view.stats().drawn == ground.size() + own);
  const std::vector<uint8_t> with = view.download_rgba();
  CHECK_FALSE(view.draw(cam, 0, viewer::GaussianDetail::Whole, &pose));  // unchanged
  // The car's pixels: many, and mostly the red body paint (roof, trunk; the rest glass and tires).
  size_t changed = 0, red = 0;
  for (size_t i = 0; i < with.size(); i += 4) {
    if (with[i] == without[i] && with[i + 1] == without[i + 1] && with[i + 2] == without[i + 2]) continue;
    ++changed;
    red += with[i] > with[i + 2] + 40;
  }
  MESSAGE("own car: " << own << " Gaussians, " << changed << " pixels changed, " << red << " red");
  CHECK(changed > 160 * 90 / 20);
  CHECK(red > changed / 3);

  // The car moved 3 m to the left: drawn again, another image.
  box.center.y = 3.0;
  const glm::dmat4 moved = scene::box_to_world(box);
  CHECK(view.draw(cam, 0, viewer::GaussianDetail::Whole, &moved));
  int max_d = 0;
  size_t differing = 0;
  rgba_diff(with, view.download_rgba(), &max_d, &differing);
  CHECK(differing > 0);
  // And gone again when no pose is given.
  CHECK(view.draw(cam, 0, viewer::GaussianDetail::Whole));
  CHECK(view.download_rgba() == without);
}

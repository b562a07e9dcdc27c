// `icube generate` end to end on the real Waymo scenario (the parked ego's
// camera over 9 s, every 3rd state, 208 x 120): a complete package that
// `icube splat render` (along the package's trajectory.json) and `icube lidar
// --gaussians` load; held-out novel views, map alignment and LiDAR agreement
// within bounds measured on it; the moving vehicles at their track poses in
// held-out frames, checked against the frames' instance buffers; the same
// bytes from a second run.
#include <doctest/doctest.h>

#include "cli_test_util.h"
#include "gpu_test_context.h"
#include "lift/package_eval.h"
#include "object_coverage.h"
#include "scene/atomic_file.h"
#include "scene/package_check.h"
#include "scene/scene_load.h"

#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <string>

using namespace icube;
namespace fs = std::filesystem;

TEST_CASE("cli: icube generate on the real Waymo scenario: a package the renderer, LiDAR and eval load; cars at "
          "their track poses" *
          doctest::test_suite("slow-gpu")) {
  const std::string waymo = test::test_data_file("maps/waymo/motion_data_one_scenario.tfrecord");
  if (waymo.empty()) return;
  test::TempDir dir("gen-waymo");
  const fs::path pkg = dir.path / "pkg", pkg2 = dir.path / "pkg2";
  const std::string args = "generate '" + waymo + "' --camera 180,180,104,60,208,120 --frames 0:91:3 --no-video --no-preview -o ";
  test::CliRun r = test::run_icube(args + "'" + pkg.string() + "'", dir.path);
  INFO(r.output);
  REQUIRE(r.code == 0);
  REQUIRE(scene::check_package(pkg.string()).complete);
  const render::FramesMeta meta = render::read_frames_meta((pkg / "frames").string());
  REQUIRE(meta.poses.size() == 31);
  const splat::SplatScene gs = splat::read_splat_scene((pkg / "gaussians" / "scene.json").string());
  CHECK(gs.static_set.size() > 50000);
  CHECK(gs.objects.size() >= 10);  // measured 26 moving vehicles seen by the camera
  CHECK(gs.frames() == 91);        // every scene state

  // The moving vehicles at their track poses: at held-out frames the objects alone cover the pixels
  // the instance buffer gives to dynamic vehicles, and few others.
  size_t dyn = 0, covered = 0, beyond = 0;
  for (size_t f : {size_t(5), size_t(15), size_t(25)}) {
    const test::ObjectCoverage c = test::object_coverage(gs, (pkg / "frames").string(), meta, f);
    MESSAGE("waymo frame " << f << ": " << c.dynamic << " dynamic pixels, " << c.covered << " covered, " << c.fringe
                           << " object pixels within 1 px of the mask, " << c.beyond << " beyond");
    dyn += c.dynamic, covered += c.covered, beyond += c.beyond;
  }
  REQUIRE(dyn > 100);
  CHECK(double(covered) >= 0.8 * double(dyn));
  CHECK(double(beyond) <= 0.15 * double(dyn));

  // The renderer along the package's trajectory, and LiDAR on the Gaussians, load the package.
  r = test::run_icube("splat render '" + (pkg / "gaussians" / "scene.json").string() + "' --trajectory '" +
                          (pkg / "trajectory.json").string() + "' --sky '" + (pkg / "gaussians" / "sky.png").string() +
                          "' -o '" + (dir.path / "render").string() + "'",
                      dir.path);
  CHECK_MESSAGE(r.code == 0, r.output);
  CHECK(fs::is_regular_file(dir.path / "render" / "000030.png"));
  r = test::run_icube("lidar --gaussians '" + (pkg / "gaussians" / "scene.json").string() + "' --scene '" + waymo +
                          "' --frames 10:11 --columns 600 -o '" + (dir.path / "lidar").string() + "'",
                      dir.path);
  CHECK_MESSAGE(r.code == 0, r.output);
  CHECK(fs::is_regular_file(dir.path / "lidar" / "lidar.json"));

  // Evaluation: the parked camera sees the same street at every frame, so held-out views are close
  // to training views (measured 22.7 dB at the lift's held-out frames); the map and LiDAR measures
  // as on the demo town.
  scene::Scene sc = scene::load_scene(waymo, scene::LoadOptions{}, nullptr);
  if (scene::tracks_unclassified(sc)) scene::classify_tracks(sc);
  lift::PackageEvalOptions o;
  o.lidar.elevations_deg = render::uniform_elevations(16, -17.6, 2.4);
  o.lidar.columns = 512;
  o.lidar_frames = 2;
  const lift::PackageEval e = lift::evaluate_package(test::gpu_context(), pkg.string(), sc, o);
  for (const lift::NovelViewRow& row : e.novel)
    MESSAGE(row.label << ": " << row.frames << " frames, PSNR " << row.psnr << " dB, SSIM " << row.ssim
                      << ", cars " << row.psnr_dynamic << " dB");
  MESSAGE("map: road edges within 2 px " << e.map.road_edges.within << ", paint median " << e.map.marking_to_map.median
                                         << " m; LiDAR in view p50 " << e.lidar.in_view.p50 << " m");
  REQUIRE(e.novel.size() == 3);
  CHECK(e.novel[0].frames > 5);
  CHECK(e.novel[0].psnr > 19.0);
  CHECK(e.novel[0].ssim > 0.45);
  CHECK(e.novel[0].psnr_dynamic > 15.0);
  // The parked camera faces a junction: no road edge within 40 m in view; the lane lines it sees cross
  // the junction, where the world has no paint (map -> paint median 6 px); the paint it sees is the
  // crosswalk's, inside the map's crosswalk polygon (measured 99.8 % within 0.5 m).
  CHECK(e.map.lane_lines.samples > 1000);
  CHECK(e.map.marking_to_map.samples > 10000);
  CHECK(e.map.marking_to_map.within > 0.9);
  CHECK(std::fabs(e.map.ground_offset_median_signed) < 0.5);
  // LiDAR: the prior's ground follows the map's elevation in 0.2 m steps, and at grazing incidence the
  // surfels' blur of a step and the voxels' step differ by decimetres (measured in-view p50 7.6 cm;
  // 5 mm on the flat demo town).
  CHECK(e.lidar.in_view.both > 500);
  CHECK(e.lidar.in_view.p50 < 0.15);

  // The same inputs: the same bytes.
  r = test::run_icube(args + "'" + pkg2.string() + "'", dir.path);
  REQUIRE(r.code == 0);
  CHECK(scene::read_file((pkg / "manifest.json").string()) == scene::read_file((pkg2 / "manifest.json").string()));
}

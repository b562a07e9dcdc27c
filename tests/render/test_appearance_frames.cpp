// `icube frames` end to end on the demo town (a two-chunk world, a 104 x 60
// camera): render writes the frames folder (rgb, sky mask, instance, meta) the
// same way twice and numbers frames as `icube buffers` does; the prompt list
// and unknown-word warnings; a bad argument writes nothing; import takes a
// video model's PNG frames or mp4 matched to the buffers, rescales the same
// aspect ratio, and refuses other counts and aspect ratios without writing.
#include <doctest/doctest.h>

#include "cli_test_util.h"

#include "render/appearance/frames_import.h"
#include "render/appearance/frames_layout.h"
#include "scene/atomic_file.h"
#include "scene/png_read.h"
#include "scene/png_write.h"
#include "video/mp4_writer.h"

#include <nlohmann/json.hpp>

#include <filesystem>
#include <string>
#include <vector>

using namespace icube;
namespace fs = std::filesystem;

namespace {

const char* kCamera = "--camera 90,90,52,30,104,60";

// The demo scene and its world, built once for every case of this file (doctest re-runs a
// case per subcase).
struct DemoWorld {
  test::TempDir dir{"frames"};
  std::string scene, world;
  bool ok = false;
  DemoWorld() {
    scene = (dir.path / "scene.json").string();
    world = (dir.path / "world.icw").string();
    ok = test::run_icube("world demo-scene -o '" + scene + "'", dir.path).code == 0 &&
         test::run_icube("world build '" + scene + "' -o '" + world + "'", dir.path).code == 0;
  }
};

const DemoWorld& demo_world() {
  static const DemoWorld d;
  REQUIRE(d.ok);
  return d;
}

// The buffers of frames 10:16:3 and our procedural frames of the same view, made once.
struct DemoClip {
  fs::path buf, clip, proc;
  bool ok = false;
  explicit DemoClip(const DemoWorld& d) {
    buf = d.dir.path / "buf";
    clip = buf / "c";
    proc = d.dir.path / "proc";
    ok = test::run_icube("buffers '" + d.world + "' --scene '" + d.scene + "' " + kCamera +
                             " --frames 10:16:3 --no-video --clip c -o '" + buf.string() + "'",
                         d.dir.path)
                 .code == 0 &&
         test::run_icube("frames render '" + d.world + "' --scene '" + d.scene + "' " + kCamera +
                             " --frames 10:16:3 -o '" + proc.string() + "'",
                         d.dir.path)
                 .code == 0;
  }
};

std::vector<fs::path> pngs(const fs::path& d) {
  std::vector<fs::path> out;
  if (fs::exists(d))
    for (const auto& e : fs::directory_iterator(d)) out.push_back(e.path());
  std::sort(out.begin(), out.end());
  return out;
}

void write_rgb(const fs::path& p, int w, int h, uint8_t base) {
  std::vector<uint8_t> px(static_cast<size_t>(w) * static_cast<size_t>(h) * 3);
  for (size_t i = 0; i < px.size(); ++i) px[i] = static_cast<uint8_t>(base + i % 7);
  scene::write_png(p.string(), px.data(), w, h, 3);
}

}  // namespace

TEST_CASE("cli: icube frames render writes the frames folder, deterministically, numbered as the buffers") {
  const DemoWorld& d = demo_world();
  const fs::path out1 = d.dir.path / "f1", out2 = d.dir.path / "f2";
  const std::string args = "frames render '" + d.world + "' --scene '" + d.scene + "' " + kCamera +
                           " --frames 10:16:3 --prompt 'A driving scene at dusk, shiny unicorns' --seed 4 -o ";
  const test::CliRun r = test::run_icube(args + "'" + out1.string() + "'", d.dir.path);
  INFO(r.output);
  REQUIRE(r.code == 0);
  CHECK(r.output.find("shiny, unicorns") != std::string::npos);  // unknown words reported
  REQUIRE(test::run_icube(args + "'" + out2.string() + "'", d.dir.path).code == 0);
  const auto rgb = pngs(out1 / "rgb");
  REQUIRE(rgb.size() == 2);
  CHECK(rgb[0].filename() == "000000.png");
  CHECK(rgb[1].filename() == "000001.png");
  for (const char* sub : {"rgb", "sky_mask", "instance"})
    for (const auto& p : pngs(out1 / sub)) CHECK(scene::read_file(p.string()) == scene::read_file((out2 / sub / p.filename()).string()));
  const scene::Image8 sky = scene::read_png((out1 / "sky_mask" / "000000.png").string(), 1);
  CHECK(sky.width == 104);
  size_t n_sky = 0, other = 0;
  for (uint8_t v : sky.pixels) n_sky += v == 255, other += v != 0 && v != 255;
  CHECK(n_sky > 0);
  CHECK(n_sky < sky.pixels.size());
  CHECK(other == 0);
  const nlohmann::json meta = nlohmann::json::parse(scene::read_file((out1 / "frames_meta.json").string()));
  CHECK(meta["format"] == "icube-frames");
  CHECK(meta["count"] == 2);
  CHECK(meta["source_frame_indices"] == std::vector<int>{10, 13});
  CHECK(meta["appearance"]["time_of_day"] == "dusk");
  CHECK(meta["poses"].size() == 2);
  // Nothing staged is left beside the output.
  for (const auto& e : fs::directory_iterator(d.dir.path)) CHECK(e.path().filename().string().find(".partial") == std::string::npos);
  fs::remove_all(out1);
  fs::remove_all(out2);
}

TEST_CASE("cli: icube frames render --list-prompts, and a bad argument writes nothing") {
  test::TempDir dir("frames-bad");
  const test::CliRun l = test::run_icube("frames render --list-prompts", dir.path);
  CHECK(l.code == 0);
  CHECK(l.output.find("nighttime -> time: night") != std::string::npos);
  CHECK(l.output.find("foggy -> weather") != std::string::npos);
  const DemoWorld& d = demo_world();
  const fs::path out = d.dir.path / "bad";
  const test::CliRun r = test::run_icube("frames render '" + d.world + "' --scene '" + d.scene + "' " + kCamera +
                                             " --frames 3:x -o '" + out.string() + "'",
                                         d.dir.path);
  CHECK(r.code != 0);
  CHECK(r.output.find("icube: error:") != std::string::npos);
  CHECK(!fs::exists(out));
  CHECK(test::run_icube("frames render -o '" + out.string() + "'", d.dir.path).code != 0);
  CHECK(!fs::exists(out));
  // A frame whose ray hits pass the texel buffer they are read through (48 M pixels, 3 texels each,
  // over lavapipe's 128 M): a clear error naming the most pixels, nothing written.
  const test::CliRun huge = test::run_icube("frames render '" + d.world + "' --scene '" + d.scene +
                                                "' --camera 8000,8000,4000,3000,8000,6000 --frames 0:1 -o '" + out.string() + "'",
                                            d.dir.path);
  CHECK(huge.code != 0);
  CHECK(huge.output.find("texels of ray hits, over this device's") != std::string::npos);
  CHECK(huge.output.find("render at most") != std::string::npos);
  CHECK(!fs::exists(out));
}

TEST_CASE("frames import: PNG frames and mp4 matched to the buffers; other counts and aspect ratios refused") {
  const DemoWorld& d = demo_world();
  static const DemoClip c(d);
  REQUIRE(c.ok);
  const fs::path& clip = c.clip;
  const fs::path& proc = c.proc;  // our own procedural frames of the same view, to compare masks

  SUBCASE("same size and same aspect ratio") {
    for (const int scale : {1, 2}) {
      CAPTURE(scale);
      const fs::path in = d.dir.path / ("in" + std::to_string(scale)), out = d.dir.path / ("out" + std::to_string(scale));
      fs::create_directories(in);
      write_rgb(in / "a.png", 104 * scale, 60 * scale, 10);
      write_rgb(in / "b.png", 104 * scale, 60 * scale, 90);
      const test::CliRun r = test::run_icube("frames import '" + in.string() + "' --buffers '" + clip.string() +
                                                 "' --prompt 'rainy night' -o '" + out.string() + "'",
                                             d.dir.path);
      INFO(r.output);
      REQUIRE(r.code == 0);
      CHECK((r.output.find("rescaled") != std::string::npos) == (scale == 2));
      const scene::Image8 img = scene::read_png((out / "rgb" / "000001.png").string(), 3);
      CHECK(img.width == 104);
      CHECK(img.height == 60);
      CHECK(std::abs(int{img.pixels[0]} - 90) <= 6);
      // The sky mask from the buffers' semantic sky agrees with the renderer's (no exact pass there).
      const scene::Image8 m1 = scene::read_png((out / "sky_mask" / "000000.png").string(), 1);
      const scene::Image8 m2 = scene::read_png((proc / "sky_mask" / "000000.png").string(), 1);
      size_t same = 0;
      for (size_t i = 0; i < m1.pixels.size(); ++i) same += m1.pixels[i] == m2.pixels[i];
      CHECK(same >= m1.pixels.size() * 995 / 1000);
      const nlohmann::json meta = nlohmann::json::parse(scene::read_file((out / "frames_meta.json").string()));
      CHECK(meta["source"] == "import");
      CHECK(meta["source_frame_indices"] == std::vector<int>{10, 13});
      CHECK(meta["appearance"]["time_of_day"] == "night");
      // The camera poses come back from the buffers' pose.tar (float32, voxel world) in our world frame:
      // the folder reads for Stage 3, with the poses our own frames of the same path carry.
      const render::FramesMeta im = render::read_frames_meta(out.string());
      const render::FramesMeta pm = render::read_frames_meta(proc.string());
      REQUIRE(im.poses.size() == 2);
      REQUIRE(pm.poses.size() == 2);
      double worst = 0.0;
      for (size_t f = 0; f < 2; ++f)
        for (int col = 0; col < 4; ++col)
          for (int row = 0; row < 4; ++row)
            worst = std::max(worst, std::fabs(im.poses[f][col][row] - pm.poses[f][col][row]));
      INFO("largest pose element difference " << worst);
      CHECK(worst < 1e-4);  // float32 in the tar: ~1e-7 relative on ~100 m
    }
  }
  SUBCASE("an mp4") {
    const fs::path mp4 = d.dir.path / "clip.mp4", out = d.dir.path / "out_mp4";
    {
      video::Mp4Writer w(mp4.string(), 104, 60);
      for (int f = 0; f < 2; ++f) w.add_frame(std::vector<uint8_t>(104 * 60 * 3, static_cast<uint8_t>(60 + 100 * f)));
      w.finish();
    }
    const test::CliRun r = test::run_icube("frames import '" + mp4.string() + "' --buffers '" + clip.string() + "' -o '" +
                                               out.string() + "'",
                                           d.dir.path);
    INFO(r.output);
    REQUIRE(r.code == 0);
    const scene::Image8 img = scene::read_png((out / "rgb" / "000001.png").string(), 3);
    CHECK(std::abs(int{img.pixels[300]} - 160) <= 8);
  }
  SUBCASE("sky masks segmented from the frames: label maps at the frames' size, binary masks; bad masks refused") {
    const fs::path in = d.dir.path / "in_sky", labels = d.dir.path / "labels", binary = d.dir.path / "binary";
    for (const auto& p : {in, labels, binary}) fs::create_directories(p);
    write_rgb(in / "a.png", 208, 120, 10);
    write_rgb(in / "b.png", 208, 120, 90);
    // Label maps at the input frames' 208 x 120: sky (10) in the top 40 rows of frame 0, the top 20 of
    // frame 1, road (0) below; binary masks at the buffers' 104 x 60: sky in the left half.
    for (int f = 0; f < 2; ++f) {
      std::vector<uint8_t> lab(208 * 120, 0), bin(104 * 60, 0);
      for (int y = 0; y < (f == 0 ? 40 : 20); ++y)
        for (int x = 0; x < 208; ++x) lab[size_t(y * 208 + x)] = 10;
      for (int y = 0; y < 60; ++y)
        for (int x = 0; x < 52; ++x) bin[size_t(y * 104 + x)] = 200;
      const std::string n = std::string(f == 0 ? "m0" : "m1") + ".png";
      scene::write_file_atomic((labels / n).string(), scene::encode_png(lab.data(), 208, 120, 1));
      scene::write_file_atomic((binary / n).string(), scene::encode_png(bin.data(), 104, 60, 1));
    }
    const fs::path out_l = d.dir.path / "out_labels", out_b = d.dir.path / "out_binary";
    test::CliRun r = test::run_icube("frames import '" + in.string() + "' --buffers '" + clip.string() +
                                         "' --sky-masks '" + labels.string() + "' --sky-label 10 -o '" + out_l.string() + "'",
                                     d.dir.path);
    INFO(r.output);
    REQUIRE(r.code == 0);
    CHECK(r.output.find("sky pixels 3120 from the masks") != std::string::npos);  // (20 + 10) rows x 104
    for (int f = 0; f < 2; ++f) {
      const scene::Image8 m = scene::read_png((out_l / "sky_mask" / render::frame_file_name(size_t(f))).string(), 1);
      REQUIRE(m.pixels.size() == 104 * 60);
      size_t wrong = 0;
      for (int y = 0; y < 60; ++y)
        for (int x = 0; x < 104; ++x) wrong += m.pixels[size_t(y * 104 + x)] != (y < (f == 0 ? 20 : 10) ? 255 : 0);
      CHECK(wrong == 0);
    }
    CHECK(render::read_frames_meta(out_l.string()).sky_mask == "segmentation");
    CHECK(render::read_frames_meta(proc.string()).sky_mask == "buffers");
    r = test::run_icube("frames import '" + in.string() + "' --buffers '" + clip.string() + "' --sky-masks '" +
                            binary.string() + "' -o '" + out_b.string() + "'",
                        d.dir.path);
    REQUIRE(r.code == 0);
    const scene::Image8 mb = scene::read_png((out_b / "sky_mask" / "000001.png").string(), 1);
    CHECK(mb.pixels[0] == 255);
    CHECK(mb.pixels[51] == 255);
    CHECK(mb.pixels[52] == 0);
    // Refused, nothing written: a mask too many, a mask of a third size.
    const fs::path out_bad = d.dir.path / "out_bad_masks";
    auto refused = [&](const fs::path& masks, const char* why) {
      const test::CliRun e = test::run_icube("frames import '" + in.string() + "' --buffers '" + clip.string() +
                                                 "' --sky-masks '" + masks.string() + "' -o '" + out_bad.string() + "'",
                                             d.dir.path);
      INFO(e.output);
      CHECK(e.code != 0);
      CHECK(e.output.find(why) != std::string::npos);
      CHECK(!fs::exists(out_bad));
    };
    const fs::path three = d.dir.path / "three_masks", odd = d.dir.path / "odd_masks";
    fs::create_directories(three);
    fs::create_directories(odd);
    for (const char* n : {"a.png", "b.png", "c.png"}) fs::copy_file(binary / "m0.png", three / n);
    refused(three, "3 sky masks, but there are 2 frames");
    const std::vector<uint8_t> small(50 * 30, 0);
    for (const char* n : {"a.png", "b.png"})
      scene::write_file_atomic((odd / n).string(), scene::encode_png(small.data(), 50, 30, 1));
    refused(odd, "50x30 is neither the buffers' 104x60 nor the frames' 208x120");
  }
  SUBCASE("refused: another count, another aspect ratio, frames of mixed sizes; nothing written") {
    const fs::path out = d.dir.path / "refused";
    auto refused = [&](const fs::path& in, const char* why) {
      const test::CliRun r = test::run_icube("frames import '" + in.string() + "' --buffers '" + clip.string() + "' -o '" +
                                                 out.string() + "'",
                                             d.dir.path);
      INFO(r.output);
      CHECK(r.code != 0);
      CHECK(r.output.find(why) != std::string::npos);
      CHECK(!fs::exists(out));
    };
    const fs::path three = d.dir.path / "three", wide = d.dir.path / "wide", mixed = d.dir.path / "mixed";
    for (const auto& p : {three, wide, mixed}) fs::create_directories(p);
    for (const char* n : {"a.png", "b.png", "c.png"}) write_rgb(three / n, 104, 60, 0);
    refused(three, "3 frames, but the guidance buffers");
    write_rgb(wide / "a.png", 120, 60, 0);
    write_rgb(wide / "b.png", 120, 60, 0);
    refused(wide, "aspect ratio");
    write_rgb(mixed / "a.png", 104, 60, 0);
    write_rgb(mixed / "b.png", 208, 120, 0);
    refused(mixed, "differ in size");
    refused(d.dir.path / "nothing_here", "neither a folder");
  }
}

TEST_CASE("frames import: area resampling keeps flat colours and averages 2 x 2 blocks") {
  std::vector<uint8_t> src(4 * 2 * 3);
  for (size_t i = 0; i < 8; ++i) src[3 * i] = (i % 2) ? 200 : 100, src[3 * i + 1] = 50, src[3 * i + 2] = 7;
  const std::vector<uint8_t> half = render::resample_rgb8(src, 4, 2, 2, 1);
  REQUIRE(half.size() == 6);
  CHECK(half[0] == 150);
  CHECK(half[1] == 50);
  CHECK(half[5] == 7);
}

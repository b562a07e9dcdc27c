// mp4 writing and reading through libavcodec (engine/video): a write/read
// round trip at odd and even sizes with upstream's x264 settings (frame count,
// size, frame rate, codec error), the temporary-file contract, and bad input
// (wrong frame sizes, no frames, files that are not videos).
#include <doctest/doctest.h>

#include "cli_test_util.h"
#include "scene/atomic_file.h"
#include "scene/input_error.h"
#include "video/mp4_reader.h"
#include "video/mp4_writer.h"
#include "video/codec_error.h"


#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

using namespace icube;

namespace {

// A guidance-like frame: flat palette regions with sharp edges (semantic
// buffer), a smooth gradient band (coordinate buffer) and a moving box.
std::vector<uint8_t> guidance_like_frame(uint32_t w, uint32_t h, uint32_t f) {
  static const uint8_t palette[5][3] = {{70, 130, 180}, {128, 64, 128}, {244, 35, 232}, {107, 142, 35}, {0, 0, 142}};
  std::vector<uint8_t> rgb(size_t{w} * h * 3);
  for (uint32_t y = 0; y < h; ++y)
    for (uint32_t x = 0; x < w; ++x) {
      uint8_t* p = &rgb[(size_t{y} * w + x) * 3];
      if (y < h / 3) {
        std::copy_n(palette[0], 3, p);  // sky
      } else if (y < h / 2) {
        p[0] = static_cast<uint8_t>(255 * x / std::max(1u, w - 1));  // gradient band
        p[1] = static_cast<uint8_t>(255 * (y - h / 3) / std::max(1u, h / 2 - h / 3));
        p[2] = 128;
      } else {
        std::copy_n(palette[1 + ((x / 23 + y / 13) % 3)], 3, p);
      }
      const uint32_t bx = (f * 3) % std::max(1u, w);
      if (x >= bx && x < bx + w / 5 && y >= h / 2 && y < h / 2 + h / 4) std::copy_n(palette[4], 3, p);
    }
  return rgb;
}

}  // namespace

TEST_CASE("mp4: frames written with upstream's x264 settings decode to the same count, size, rate and pixels") {
  test::TempDir tmp("mp4-roundtrip");
  const std::string dir = tmp.path.string();
  // 832x480 is upstream's size (scaled down 4x here); 37x23 is odd in both dimensions (padded to 38x24).
  for (const auto& [w, h] : {std::pair<uint32_t, uint32_t>{208, 120}, {37, 23}}) {
    CAPTURE(w);
    CAPTURE(h);
    const std::string path = dir + "/clip " + std::to_string(w) + ".mp4";
    const uint32_t frames = 13;
    std::vector<std::vector<uint8_t>> ref;
    {
      video::Mp4Writer mw(path, w, h);  // upstream defaults: veryslow, crf 23.5, 10 fps, yuv420p
      for (uint32_t f = 0; f < frames; ++f) {
        ref.push_back(guidance_like_frame(w, h, f));
        mw.add_frame(ref.back());
      }
      CHECK(mw.frames() == frames);
      CHECK(!std::filesystem::exists(path));  // only the temporary so far
      mw.finish();
    }
    REQUIRE(std::filesystem::exists(path));
    const video::DecodedVideo dv = video::read_video(path);
    CHECK(dv.frames.size() == frames);
    CHECK(dv.width == w + (w & 1));
    CHECK(dv.height == h + (h & 1));
    CHECK(dv.fps == doctest::Approx(10.0));
    double worst_mean = 0.0, worst_psnr = 1e9, worst_interior = 1.0, worst_bias = 0.0;
    for (uint32_t f = 0; f < frames; ++f) {
      const test::CodecError e = test::codec_error(ref[f], w, h, dv.frames[f], dv.width);
      worst_mean = std::max(worst_mean, e.mean_abs);
      worst_psnr = std::min(worst_psnr, e.psnr_db);
      worst_interior = std::min(worst_interior, e.interior_within);
      worst_bias = std::max(worst_bias, e.worst_bias());
      // In display order: frame f is closer to reference f than to its neighbours (the box moves).
      for (const uint32_t g : {f - 1, f + 1})
        if (g < frames) CHECK(test::codec_error(ref[g], w, h, dv.frames[f], dv.width).mean_abs > e.mean_abs);
    }
    MESSAGE(w << "x" << h << ": worst frame mean |error| " << worst_mean << " levels, PSNR " << worst_psnr
              << " dB, bias " << worst_bias << ", flat interiors within " << test::kInteriorLevels
              << " levels: " << worst_interior);
    // The error budget (docs/guidance-buffers.md), measured with Debian 12's libx264 164 (crf 23.5,
    // veryslow): 208x120 mean 5.9 levels, PSNR 25.6 dB, bias 0.2, interiors 0.998 within 8 levels;
    // 37x23 (nearly all edges, one padding row and column) mean 16.0, bias 2.6.
    if (w > 100) {
      CHECK(worst_bias < 1.0);
      CHECK(worst_interior > 0.99);
      CHECK(worst_mean < 7.5);
      CHECK(worst_psnr > 23.0);
    } else {
      CHECK(worst_bias < 4.0);
      CHECK(worst_mean < 20.0);
    }
    // Only the first max_frames when asked.
    CHECK(video::read_video(path, 4).frames.size() == 4);
  }
}

TEST_CASE("mp4: a writer that is not finished leaves no file; bad frames and empty videos are errors") {
  test::TempDir tmp("mp4-contract");
  const std::string dir = tmp.path.string();
  const std::string path = dir + "/a.mp4";
  {
    video::Mp4Options o;
    o.preset = "ultrafast";
    video::Mp4Writer mw(path, 16, 16, o);
    mw.add_frame(std::vector<uint8_t>(16 * 16 * 3, 7));
    CHECK_THROWS_WITH_AS(mw.add_frame(std::vector<uint8_t>(10, 0)),
                         doctest::Contains("a.mp4: mp4 frame of 10 bytes, expected 768"), std::invalid_argument);
  }
  CHECK(std::filesystem::is_empty(dir));  // the temporary is gone, no mp4
  {
    video::Mp4Writer mw(path, 16, 16);
    CHECK_THROWS_WITH_AS(mw.finish(), doctest::Contains("no frame was written"), std::runtime_error);
  }
  CHECK(std::filesystem::is_empty(dir));
  CHECK_THROWS_AS(video::Mp4Writer(path, 0, 16), std::invalid_argument);
  video::Mp4Options bad;
  bad.preset = "warp-speed";
  CHECK_THROWS_WITH_AS(video::Mp4Writer(path, 16, 16, bad), doctest::Contains("cannot open libx264"),
                       std::runtime_error);
  CHECK(std::filesystem::is_empty(dir));
  CHECK_THROWS_WITH_AS(video::Mp4Writer(dir + "/no/such/folder/b.mp4", 16, 16), doctest::Contains("b.mp4"),
                       std::runtime_error);

  // Reading: a missing file, a text file, a truncated mp4.
  CHECK_THROWS_WITH_AS(video::read_video(dir + "/missing.mp4"), doctest::Contains("missing.mp4: cannot open as a video"),
                       scene::InputError);
  scene::write_file_atomic(dir + "/text.mp4", "not a video at all\n");
  CHECK_THROWS_AS(video::read_video(dir + "/text.mp4"), scene::InputError);
  {
    video::Mp4Options o;
    o.preset = "ultrafast";
    video::Mp4Writer mw(dir + "/good.mp4", 32, 32, o);
    for (uint32_t f = 0; f < 5; ++f) mw.add_frame(guidance_like_frame(32, 32, f));
    mw.finish();
  }
  const std::string good = scene::read_file(dir + "/good.mp4");
  scene::write_file_atomic(dir + "/cut.mp4", good.substr(0, good.size() / 3));
  try {
    const video::DecodedVideo dv = video::read_video(dir + "/cut.mp4");
    CHECK(dv.frames.size() < 5);  // a cut file may still yield its first frames
  } catch (const scene::InputError& e) {
    CHECK(std::string(e.what()).find("cut.mp4") != std::string::npos);
  }
}

// `icube video frames` (tools/cmd_video.cpp): an mp4 the engine wrote decodes
// into NNNNNN.png frames numbered from 0, --max limits them, and a file that is
// not a video exits 1 with one line naming it and leaves no output folder.
#include <doctest/doctest.h>

#include "cli_test_util.h"
#include "test_stb_image.h"
#include "video/mp4_writer.h"

#include <filesystem>
#include <string>
#include <vector>

using namespace icube;

TEST_CASE("cli: icube video frames decodes an mp4 into numbered PNGs") {
  test::TempDir tmp("cli-video");
  const std::string mp4 = (tmp.path / "in.mp4").string();
  {
    video::Mp4Options o;
    o.preset = "ultrafast";
    video::Mp4Writer w(mp4, 48, 32, o);
    for (int f = 0; f < 7; ++f) w.add_frame(std::vector<uint8_t>(48 * 32 * 3, static_cast<uint8_t>(30 * f)));
    w.finish();
  }
  test::CliRun r = test::run_icube("video frames '" + mp4 + "' -o '" + (tmp.path / "frames").string() + "'", tmp.path);
  INFO(r.output);
  REQUIRE(r.code == 0);
  CHECK(r.output.find("7 frames 48x32 at 10 fps") != std::string::npos);
  for (int f = 0; f < 7; ++f) {
    const std::string png = (tmp.path / "frames" / ("00000" + std::to_string(f) + ".png")).string();
    int w = 0, h = 0, c = 0;
    unsigned char* px = stbi_load(png.c_str(), &w, &h, &c, 3);
    REQUIRE(px != nullptr);
    CHECK(w == 48);
    CHECK(h == 32);
    CHECK(std::abs(int{px[100]} - 30 * f) <= 2);  // a flat grey frame survives the codec
    stbi_image_free(px);
  }
  CHECK(!std::filesystem::exists(tmp.path / "frames" / "000007.png"));

  r = test::run_icube("video frames '" + mp4 + "' --max 3 -o '" + (tmp.path / "three").string() + "'", tmp.path);
  CHECK(r.code == 0);
  CHECK(std::filesystem::exists(tmp.path / "three" / "000002.png"));
  CHECK(!std::filesystem::exists(tmp.path / "three" / "000003.png"));

  scene::write_file_atomic((tmp.path / "notes.mp4").string(), "hello\n");
  r = test::run_icube("video frames '" + (tmp.path / "notes.mp4").string() + "' -o '" + (tmp.path / "bad").string() + "'",
                      tmp.path);
  CHECK(r.code != 0);
  CHECK(r.output.find("notes.mp4: cannot open as a video") != std::string::npos);
  CHECK(!std::filesystem::exists(tmp.path / "bad"));
  r = test::run_icube("video frames '" + mp4 + "' -o '" + (tmp.path / "frames").string() + "'", tmp.path);
  CHECK(r.code != 0);  // the folder is not empty
  CHECK(r.output.find("exists and is not empty") != std::string::npos);
  r = test::run_icube("video frames --help", tmp.path);
  CHECK(r.code == 0);
}

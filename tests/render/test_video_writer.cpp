// mp4 previews through an external ffmpeg (engine/render/buffers/video_writer.h):
// the raw-RGB pipe protocol against a stand-in `ffmpeg` script (bytes, frame
// size, arguments), a failing encoder, an encoder that stops reading, PATH
// lookup, and — when a real ffmpeg and ffprobe are installed — an encoded odd-
// sized clip (padded to even, yuv420p, every frame present).
#include <doctest/doctest.h>

#include "render/buffers/video_writer.h"
#include "scene/atomic_file.h"

#include <sys/stat.h>
#include <unistd.h>

#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

using namespace icube;

namespace {

std::string temp_dir(const std::string& name) {
  const auto p = std::filesystem::temp_directory_path() / ("icube-video-" + name + "-" + std::to_string(getpid()));
  std::filesystem::remove_all(p);
  std::filesystem::create_directories(p);
  return p.string();
}

// An executable shell script standing in for ffmpeg.
std::string fake_ffmpeg(const std::string& dir, const std::string& body) {
  const std::string path = dir + "/ffmpeg";
  scene::write_file_atomic(path, "#!/bin/sh\n" + body + "\n");
  chmod(path.c_str(), 0755);
  return path;
}

std::string slurp(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

std::string run_capture(const std::string& cmd) {
  std::string out;
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return out;
  char buf[256];
  while (std::fgets(buf, sizeof buf, p)) out += buf;
  pclose(p);
  return out;
}

std::vector<uint8_t> frame(uint32_t w, uint32_t h, uint8_t seed) {
  std::vector<uint8_t> rgb(size_t{w} * h * 3);
  for (size_t i = 0; i < rgb.size(); ++i) rgb[i] = static_cast<uint8_t>(i * 7 + seed);
  return rgb;
}

}  // namespace

TEST_CASE("video writer: raw RGB24 frames reach the encoder byte for byte, with the frame size in its arguments") {
  const std::string dir = temp_dir("pipe");
  // Records its arguments, then copies stdin to the output path (the last argument).
  const std::string ff = fake_ffmpeg(dir, "for a; do last=\"$a\"; done\necho \"$@\" > \"" + dir + "/args\"\ncat > \"$last\"");
  const uint32_t w = 33, h = 17;
  render::VideoWriter v(ff, dir + "/out file.mp4", w, h, 10.0);
  std::string expect;
  for (uint8_t k = 0; k < 3; ++k) {
    const auto f = frame(w, h, k);
    v.add_frame(f);
    expect.append(f.begin(), f.end());
  }
  CHECK_THROWS_AS(v.add_frame(std::vector<uint8_t>(10)), std::invalid_argument);
  v.finish();
  CHECK(slurp(dir + "/out file.mp4") == expect);
  const std::string args = slurp(dir + "/args");
  CHECK(args.find("-f rawvideo -pix_fmt rgb24 -s 33x17 -r 10") != std::string::npos);
  CHECK(args.find("-c:v libx264") != std::string::npos);
  CHECK(args.find("-pix_fmt yuv420p") != std::string::npos);
  CHECK_THROWS_AS(v.add_frame(frame(w, h, 0)), std::logic_error);  // finished
  std::filesystem::remove_all(dir);
}

TEST_CASE("video writer: a failing or vanishing encoder is an error naming the file, not a crash") {
  const std::string dir = temp_dir("fail");
  std::signal(SIGPIPE, SIG_IGN);  // as icube buffers does: a dying ffmpeg must not kill the process
  {
    const std::string ff = fake_ffmpeg(dir, "cat > /dev/null\nexit 3");
    render::VideoWriter v(ff, dir + "/a.mp4", 8, 8);
    v.add_frame(frame(8, 8, 1));
    try {
      v.finish();
      FAIL("finish() should throw");
    } catch (const std::runtime_error& e) {
      const std::string msg = e.what();
      CHECK(msg.find(dir + "/a.mp4") != std::string::npos);
      CHECK(msg.find("exit status 3") != std::string::npos);
    }
  }
  {
    // Exits without reading: writes fail once the pipe buffer is full.
    const std::string ff = fake_ffmpeg(dir, "exit 0");
    render::VideoWriter v(ff, dir + "/b.mp4", 256, 256);
    bool threw = false;
    try {
      for (int i = 0; i < 64; ++i) v.add_frame(frame(256, 256, static_cast<uint8_t>(i)));
      v.finish();
    } catch (const std::runtime_error& e) {
      threw = true;
      CHECK(std::string(e.what()).find(dir + "/b.mp4") != std::string::npos);
    }
    CHECK(threw);
  }
  std::filesystem::remove_all(dir);
}

TEST_CASE("video writer: find_on_path finds executables only") {
  const std::string dir = temp_dir("path");
  fake_ffmpeg(dir, "exit 0");
  scene::write_file_atomic(dir + "/not-exec", "x");
  const char* old = std::getenv("PATH");
  const std::string saved = old ? old : "";
  setenv("PATH", ("/nonexistent::" + dir).c_str(), 1);
  CHECK(render::find_on_path("ffmpeg") == dir + "/ffmpeg");
  CHECK(render::find_on_path("not-exec").empty());
  CHECK(render::find_on_path("no-such-tool").empty());
  setenv("PATH", saved.c_str(), 1);
  std::filesystem::remove_all(dir);
}

TEST_CASE("video writer: a real ffmpeg encodes an odd-sized clip padded to even, every frame present") {
  const std::string ffmpeg = render::find_on_path("ffmpeg"), ffprobe = render::find_on_path("ffprobe");
  if (ffmpeg.empty() || ffprobe.empty()) {
    MESSAGE("skipped: no ffmpeg/ffprobe on PATH (Debian: apt install ffmpeg)");
    return;
  }
  const std::string dir = temp_dir("real");
  const std::string out = dir + "/clip.mp4";
  render::VideoWriter v(ffmpeg, out, 33, 17, 10.0);
  for (uint8_t k = 0; k < 7; ++k) v.add_frame(frame(33, 17, static_cast<uint8_t>(k * 30)));
  v.finish();
  const std::string probe = run_capture("'" + ffprobe +
                                        "' -v error -count_frames -select_streams v:0 -show_entries "
                                        "stream=codec_name,width,height,pix_fmt,nb_read_frames,r_frame_rate -of "
                                        "default=noprint_wrappers=1 '" + out + "'");
  INFO(probe);
  CHECK(probe.find("codec_name=h264") != std::string::npos);
  CHECK(probe.find("width=34") != std::string::npos);
  CHECK(probe.find("height=18") != std::string::npos);
  CHECK(probe.find("pix_fmt=yuv420p") != std::string::npos);
  CHECK(probe.find("r_frame_rate=10/1") != std::string::npos);
  CHECK(probe.find("nb_read_frames=7") != std::string::npos);
  std::filesystem::remove_all(dir);
}

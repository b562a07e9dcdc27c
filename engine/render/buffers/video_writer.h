// Optional mp4 previews through an external `ffmpeg` (detected on PATH at run
// time; never a build dependency). Frames are piped as raw RGB24 at 10 fps
// and encoded with libx264, crf 23.5, yuv420p (odd sizes padded to even), as
// InfiniCube's viewing videos (conventions §10.4; lossy, for viewing only).
#pragma once

#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

namespace icube::render {

// Full path of an executable `name` on PATH, or empty.
std::string find_on_path(const std::string& name);

class VideoWriter {
 public:
  // Starts `ffmpeg_path` writing `path`; throws std::runtime_error when it cannot start.
  VideoWriter(const std::string& ffmpeg_path, const std::string& path, uint32_t width, uint32_t height, double fps = 10.0);
  ~VideoWriter();
  VideoWriter(const VideoWriter&) = delete;
  VideoWriter& operator=(const VideoWriter&) = delete;

  void add_frame(const std::vector<uint8_t>& rgb);  // width·height·3 bytes
  // Waits for ffmpeg; throws std::runtime_error naming the file when it failed.
  void finish();

 private:
  std::string path_;
  uint32_t width_, height_;
  FILE* pipe_ = nullptr;
};

}  // namespace icube::render

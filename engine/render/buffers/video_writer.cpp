// ffmpeg mp4 writer; see video_writer.h.
#include "render/buffers/video_writer.h"

#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <sstream>
#include <stdexcept>

namespace icube::render {

namespace {

std::string shell_quote(const std::string& s) {
  std::string out = "'";
  for (char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

}  // namespace

std::string find_on_path(const std::string& name) {
  const char* path = std::getenv("PATH");
  if (!path) return {};
  std::stringstream ss(path);
  std::string dir;
  while (std::getline(ss, dir, ':')) {
    if (dir.empty()) continue;
    const std::string p = dir + "/" + name;
    if (access(p.c_str(), X_OK) == 0) return p;
  }
  return {};
}

VideoWriter::VideoWriter(const std::string& ffmpeg, const std::string& path, uint32_t width, uint32_t height, double fps)
    : path_(path), width_(width), height_(height) {
  std::ostringstream cmd;
  cmd << shell_quote(ffmpeg) << " -nostdin -y -loglevel error -f rawvideo -pix_fmt rgb24 -s " << width << "x" << height
      << " -r " << fps << " -i - -vf 'pad=ceil(iw/2)*2:ceil(ih/2)*2' -c:v libx264 -crf 23.5 -pix_fmt yuv420p "
      << shell_quote(path);
  pipe_ = popen(cmd.str().c_str(), "w");
  if (!pipe_) throw std::runtime_error(path + ": cannot start ffmpeg");
}

VideoWriter::~VideoWriter() {
  if (pipe_) pclose(pipe_);
}

void VideoWriter::add_frame(const std::vector<uint8_t>& rgb) {
  if (rgb.size() != size_t{width_} * height_ * 3) throw std::invalid_argument("VideoWriter: frame size differs");
  if (!pipe_) throw std::logic_error("VideoWriter: finished");
  if (std::fwrite(rgb.data(), 1, rgb.size(), pipe_) != rgb.size())
    throw std::runtime_error(path_ + ": ffmpeg stopped reading frames");
}

void VideoWriter::finish() {
  if (!pipe_) return;
  const int status = pclose(pipe_);
  pipe_ = nullptr;
  if (status == -1 || !WIFEXITED(status) || WEXITSTATUS(status) != 0)
    throw std::runtime_error(path_ + ": ffmpeg failed (exit status " + std::to_string(WEXITSTATUS(status)) + ")");
}

}  // namespace icube::render

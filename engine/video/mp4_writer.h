// H.264 mp4 writer on Debian's libavcodec/libavformat/libswscale (libx264),
// always available: no external ffmpeg binary.
//
// Defaults are the encoding of InfiniCube's guidance and generated videos
// (`infinicube/utils/fileio_utils.py::write_video_file`, imageio-ffmpeg with
// its "jiahui" output parameters): libx264, yuv420p, 10 fps, preset veryslow,
// crf 23.5, g 250, bf 3, sc_threshold 60, qcomp 0.5, psy-rd 0.3:0, aq-mode 2,
// aq-strength 0.8, motion estimation umh, closed GOPs, movflags +faststart.
// RGB -> YUV is swscale's default (BT.601 matrix, limited range, bicubic
// chroma). yuv420p needs even sizes: an odd width or height is padded by one
// black column/row (imageio would rescale to a multiple of 16 instead; 832x480
// and 1280x720 are unaffected). Frames go to "<path>.tmp-<pid>" and the file is
// renamed into place by finish(), so a failure never leaves a half-written mp4.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace icube::video {

struct Mp4Options {
  int fps = 10;
  std::string preset = "veryslow";  // x264 preset: ultrafast ... veryslow (speed against file size)
  double crf = 23.5;
  bool upstream_tuning = true;  // the g/bf/sc_threshold/qcomp/psy-rd/aq/me options above
  int threads = 0;              // x264 threads, 0 = automatic
  // The same frames give the same bytes: x264's macroblock-tree rate control off (it does not
  // repeat itself from run to run); a little larger files at the same CRF.
  bool deterministic = true;
};

// Sets libav's log level to errors only (once per process); the writer and reader call it.
void quiet_libav();

// The x264 preset names, fastest first.
const std::vector<std::string>& x264_presets();

class Mp4Writer {
 public:
  // Opens the encoder and the temporary output; throws std::runtime_error naming `path`.
  Mp4Writer(const std::string& path, uint32_t width, uint32_t height, const Mp4Options& opts = {});
  ~Mp4Writer();  // without finish(): the temporary is removed
  Mp4Writer(const Mp4Writer&) = delete;
  Mp4Writer& operator=(const Mp4Writer&) = delete;

  // One frame of width*height*3 bytes, RGB8, rows top to bottom.
  void add_frame(const std::vector<uint8_t>& rgb);
  // Drains the encoder, writes the trailer and renames the file into place.
  void finish();

  uint32_t width() const;
  uint32_t height() const;
  size_t frames() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace icube::video

// Small helpers shared by the libav-based writer and reader (engine/video).
#pragma once

extern "C" {
#include <libavutil/error.h>
}

#include <string>

namespace icube::video {

// libav's text for an AVERROR code.
inline std::string av_error(int code) {
  char buf[AV_ERROR_MAX_STRING_SIZE] = {};
  av_strerror(code, buf, sizeof buf);
  return buf;
}

}  // namespace icube::video

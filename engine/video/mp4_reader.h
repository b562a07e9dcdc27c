// Decodes a video file (mp4/H.264, or anything Debian's libavformat and
// libavcodec read) into RGB8 frames, for tests of the writer and for importing
// frames a video model wrote (InfiniCube's `video_480p_front.mp4`).
// YUV -> RGB is swscale's default (BT.601, limited range unless the stream says
// full range), so a write/read round trip differs from the input only by the
// codec's loss and the 4:2:0 chroma subsampling.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace icube::video {

struct DecodedVideo {
  uint32_t width = 0, height = 0;  // coded display size (a writer's padding included)
  double fps = 0.0;                // average frame rate the container states, 0 when unknown
  std::vector<std::vector<uint8_t>> frames;  // width*height*3 RGB8 each, in display order
};

// Reads every frame (at most max_frames when > 0). Throws scene::InputError
// naming the file when it cannot be opened, has no video stream, or does not decode.
DecodedVideo read_video(const std::string& path, size_t max_frames = 0);

}  // namespace icube::video

// libavformat/libavcodec video decoder into RGB8; see mp4_reader.h.
#include "video/mp4_reader.h"

#include "scene/input_error.h"
#include "video/av_util.h"
#include "video/mp4_writer.h"

extern "C" {
#include <libavcodec/avcodec.h>
#include <libavformat/avformat.h>
#include <libswscale/swscale.h>
}

#include <cstddef>
#include <cstring>
#include <string>

namespace icube::video {

namespace {

struct Decoder {
  std::string path;
  AVFormatContext* fmt = nullptr;
  AVCodecContext* dec = nullptr;
  AVFrame* frame = nullptr;
  AVFrame* rgb_frame = nullptr;  // swscale's destination: libav-aligned rows (swscale may write past a tight row)
  AVPacket* packet = nullptr;
  SwsContext* sws = nullptr;
  int stream = -1;

  [[noreturn]] void fail(const std::string& where, const std::string& what, int code = 0) const {
    throw scene::InputError(path, where, what + (code < 0 ? " (" + av_error(code) + ")" : ""));
  }

  ~Decoder() {
    sws_freeContext(sws);
    av_packet_free(&packet);
    av_frame_free(&frame);
    av_frame_free(&rgb_frame);
    avcodec_free_context(&dec);
    avformat_close_input(&fmt);
  }

  // Converts the decoded frame to RGB8 and appends it.
  void take(DecodedVideo& out) {
    if (frame->width <= 0 || frame->height <= 0) fail("frame " + std::to_string(out.frames.size()), "empty frame");
    if (out.frames.empty()) {
      out.width = static_cast<uint32_t>(frame->width);
      out.height = static_cast<uint32_t>(frame->height);
    } else if (static_cast<uint32_t>(frame->width) != out.width || static_cast<uint32_t>(frame->height) != out.height) {
      fail("frame " + std::to_string(out.frames.size()), "frame size changes within the video");
    }
    sws = sws_getCachedContext(sws, frame->width, frame->height, static_cast<AVPixelFormat>(frame->format),
                               frame->width, frame->height, AV_PIX_FMT_RGB24,
                               SWS_BICUBIC | SWS_ACCURATE_RND | SWS_FULL_CHR_H_INT, nullptr, nullptr, nullptr);
    if (!sws) fail("frame " + std::to_string(out.frames.size()), "no converter from this pixel format to RGB");
    if (!rgb_frame) {
      rgb_frame = av_frame_alloc();
      if (!rgb_frame) fail("", "out of memory");
      rgb_frame->format = AV_PIX_FMT_RGB24;
      rgb_frame->width = frame->width;
      rgb_frame->height = frame->height;
      const int rc = av_frame_get_buffer(rgb_frame, 0);
      if (rc < 0) fail("", "out of memory", rc);
    }
    sws_scale(sws, frame->data, frame->linesize, 0, frame->height, rgb_frame->data, rgb_frame->linesize);
    const size_t row = size_t{out.width} * 3;
    std::vector<uint8_t> rgb(row * out.height);
    for (uint32_t y = 0; y < out.height; ++y)
      std::memcpy(rgb.data() + y * row, rgb_frame->data[0] + static_cast<ptrdiff_t>(y) * rgb_frame->linesize[0], row);
    out.frames.push_back(std::move(rgb));
  }

  // Receives every frame the decoder has; false once max_frames are in.
  bool drain(DecodedVideo& out, size_t max_frames) {
    while (true) {
      const int rc = avcodec_receive_frame(dec, frame);
      if (rc == AVERROR(EAGAIN) || rc == AVERROR_EOF) return true;
      if (rc < 0) fail("frame " + std::to_string(out.frames.size()), "does not decode", rc);
      take(out);
      av_frame_unref(frame);
      if (max_frames && out.frames.size() >= max_frames) return false;
    }
  }
};

}  // namespace

DecodedVideo read_video(const std::string& path, size_t max_frames) {
  quiet_libav();
  Decoder d;
  d.path = path;
  int rc = avformat_open_input(&d.fmt, path.c_str(), nullptr, nullptr);
  if (rc < 0) d.fail("", "cannot open as a video", rc);
  rc = avformat_find_stream_info(d.fmt, nullptr);
  if (rc < 0) d.fail("", "no stream information", rc);
  const AVCodec* codec = nullptr;
  d.stream = av_find_best_stream(d.fmt, AVMEDIA_TYPE_VIDEO, -1, -1, &codec, 0);
  if (d.stream < 0 || !codec) d.fail("", "no video stream this libavcodec decodes", d.stream);
  const AVStream* st = d.fmt->streams[d.stream];
  d.dec = avcodec_alloc_context3(codec);
  if (!d.dec) d.fail("", "out of memory");
  rc = avcodec_parameters_to_context(d.dec, st->codecpar);
  if (rc < 0) d.fail("", "bad stream parameters", rc);
  rc = avcodec_open2(d.dec, codec, nullptr);
  if (rc < 0) d.fail("", std::string("cannot open the ") + codec->name + " decoder", rc);
  d.frame = av_frame_alloc();
  d.packet = av_packet_alloc();
  if (!d.frame || !d.packet) d.fail("", "out of memory");

  DecodedVideo out;
  if (st->avg_frame_rate.num > 0 && st->avg_frame_rate.den > 0) out.fps = av_q2d(st->avg_frame_rate);
  bool more = true;
  while (more) {
    rc = av_read_frame(d.fmt, d.packet);
    if (rc == AVERROR_EOF) break;
    if (rc < 0) d.fail("packet after frame " + std::to_string(out.frames.size()), "cannot read", rc);
    if (d.packet->stream_index == d.stream) {
      rc = avcodec_send_packet(d.dec, d.packet);
      av_packet_unref(d.packet);
      if (rc < 0 && rc != AVERROR(EAGAIN)) d.fail("frame " + std::to_string(out.frames.size()), "does not decode", rc);
      more = d.drain(out, max_frames);
    } else {
      av_packet_unref(d.packet);
    }
  }
  if (more) {
    avcodec_send_packet(d.dec, nullptr);  // flush
    d.drain(out, max_frames);
  }
  if (out.frames.empty()) d.fail("", "the video has no frame");
  return out;
}

}  // namespace icube::video

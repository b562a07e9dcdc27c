// libavcodec/libavformat H.264 mp4 writer; see mp4_writer.h.
#include "video/mp4_writer.h"

#include "video/av_util.h"

extern "C" {
#include <libavcodec/avcodec.h>
#include <libavformat/avformat.h>
#include <libavutil/log.h>
#include <libavutil/opt.h>
#include <libswscale/swscale.h>
}

#include <unistd.h>

#include <cstddef>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <stdexcept>
#include <string>

namespace icube::video {

namespace {

std::string number(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%g", v);
  return b;
}

}  // namespace

void quiet_libav() {
  static const bool once = [] {
    av_log_set_level(AV_LOG_ERROR);  // x264's banner and statistics are not ours to print
    return true;
  }();
  (void)once;
}

const std::vector<std::string>& x264_presets() {
  static const std::vector<std::string> p = {"ultrafast", "superfast", "veryfast", "faster", "fast",
                                             "medium",    "slow",      "slower",   "veryslow"};
  return p;
}

struct Mp4Writer::Impl {
  std::string path, tmp;
  uint32_t width = 0, height = 0, coded_w = 0, coded_h = 0;
  size_t frames = 0;
  AVFormatContext* fmt = nullptr;
  AVCodecContext* enc = nullptr;
  AVStream* stream = nullptr;
  AVFrame* frame = nullptr;
  AVFrame* rgb = nullptr;  // swscale's source: libav-aligned rows, zero (black) padding for odd sizes
  AVPacket* packet = nullptr;
  SwsContext* sws = nullptr;
  bool file_open = false, header_written = false, finished = false;

  [[noreturn]] void fail(const std::string& what, int code) const {
    throw std::runtime_error(path + ": mp4 encoding: " + what + (code < 0 ? " (" + av_error(code) + ")" : ""));
  }

  // Sends `f` (nullptr = flush) and writes every packet the encoder returns.
  void encode(AVFrame* f) {
    int rc = avcodec_send_frame(enc, f);
    if (rc < 0) fail("send frame", rc);
    while (true) {
      rc = avcodec_receive_packet(enc, packet);
      if (rc == AVERROR(EAGAIN) || rc == AVERROR_EOF) return;
      if (rc < 0) fail("receive packet", rc);
      av_packet_rescale_ts(packet, enc->time_base, stream->time_base);
      packet->stream_index = stream->index;
      rc = av_interleaved_write_frame(fmt, packet);  // takes the packet's reference
      if (rc < 0) fail("write packet", rc);
    }
  }

  ~Impl() {
    sws_freeContext(sws);
    av_packet_free(&packet);
    av_frame_free(&frame);
    av_frame_free(&rgb);
    avcodec_free_context(&enc);
    if (fmt) {
      if (file_open) avio_closep(&fmt->pb);
      avformat_free_context(fmt);
    }
    if (!finished && !tmp.empty()) {
      std::error_code ec;
      std::filesystem::remove(tmp, ec);
    }
  }
};

Mp4Writer::Mp4Writer(const std::string& path, uint32_t width, uint32_t height, const Mp4Options& o)
    : impl_(std::make_unique<Impl>()) {
  quiet_libav();
  Impl& m = *impl_;
  m.path = path;
  m.tmp = path + ".tmp-" + std::to_string(getpid());
  if (width == 0 || height == 0 || width > 16384 || height > 16384)
    throw std::invalid_argument(path + ": mp4 frame size " + std::to_string(width) + "x" + std::to_string(height) +
                                " is outside 1..16384");
  if (o.fps <= 0 || o.fps > 1000) throw std::invalid_argument(path + ": mp4 frame rate " + std::to_string(o.fps));
  m.width = width;
  m.height = height;
  m.coded_w = width + (width & 1u);
  m.coded_h = height + (height & 1u);

  int rc = avformat_alloc_output_context2(&m.fmt, nullptr, "mp4", m.tmp.c_str());
  if (rc < 0 || !m.fmt) m.fail("no mp4 muxer", rc);
  const AVCodec* codec = avcodec_find_encoder_by_name("libx264");
  if (!codec) m.fail("libavcodec has no libx264 encoder (Debian's libavcodec59 has it)", 0);
  m.enc = avcodec_alloc_context3(codec);
  if (!m.enc) m.fail("out of memory", 0);
  m.enc->width = static_cast<int>(m.coded_w);
  m.enc->height = static_cast<int>(m.coded_h);
  m.enc->pix_fmt = AV_PIX_FMT_YUV420P;
  m.enc->time_base = AVRational{1, o.fps};
  m.enc->framerate = AVRational{o.fps, 1};
  m.enc->thread_count = o.threads;
  if (o.upstream_tuning) {
    m.enc->gop_size = 250;          // -g 250
    m.enc->max_b_frames = 3;        // -bf 3
    m.enc->qcompress = 0.5f;        // -qcomp 0.5
    m.enc->flags |= AV_CODEC_FLAG_CLOSED_GOP;  // -flags +cgop
  }
  if (m.fmt->oformat->flags & AVFMT_GLOBALHEADER) m.enc->flags |= AV_CODEC_FLAG_GLOBAL_HEADER;

  AVDictionary* opts = nullptr;
  av_dict_set(&opts, "preset", o.preset.c_str(), 0);
  av_dict_set(&opts, "crf", number(o.crf).c_str(), 0);
  if (o.upstream_tuning) {
    av_dict_set(&opts, "sc_threshold", "60", 0);
    av_dict_set(&opts, "psy-rd", "0.3:0", 0);
    av_dict_set(&opts, "aq-mode", "2", 0);
    av_dict_set(&opts, "aq-strength", "0.8", 0);
    av_dict_set(&opts, "motion-est", "umh", 0);
  }
  // x264's macroblock-tree rate control gives other bytes for the same frames from run to run
  // (measured with libx264 164 even on one thread: 1-2 of 4 encodes of 53 frames alike, under
  // load); without it every encode is the same file.
  if (o.deterministic) av_dict_set(&opts, "x264-params", "mbtree=0", 0);
  rc = avcodec_open2(m.enc, codec, &opts);
  const AVDictionaryEntry* unused = av_dict_get(opts, "", nullptr, AV_DICT_IGNORE_SUFFIX);
  const std::string unused_key = unused ? unused->key : "";
  av_dict_free(&opts);
  if (rc < 0) m.fail("cannot open libx264 (preset \"" + o.preset + "\")", rc);
  if (!unused_key.empty()) m.fail("libx264 does not know the option \"" + unused_key + "\"", 0);

  m.stream = avformat_new_stream(m.fmt, nullptr);
  if (!m.stream) m.fail("out of memory", 0);
  m.stream->time_base = m.enc->time_base;
  m.stream->avg_frame_rate = m.enc->framerate;
  rc = avcodec_parameters_from_context(m.stream->codecpar, m.enc);
  if (rc < 0) m.fail("stream parameters", rc);

  rc = avio_open(&m.fmt->pb, m.tmp.c_str(), AVIO_FLAG_WRITE);
  if (rc < 0) m.fail("cannot create " + m.tmp, rc);
  m.file_open = true;
  AVDictionary* mux = nullptr;
  if (o.upstream_tuning) av_dict_set(&mux, "movflags", "+faststart", 0);
  rc = avformat_write_header(m.fmt, &mux);
  av_dict_free(&mux);
  if (rc < 0) m.fail("write header", rc);
  m.header_written = true;

  m.frame = av_frame_alloc();
  m.rgb = av_frame_alloc();
  m.packet = av_packet_alloc();
  if (!m.frame || !m.rgb || !m.packet) m.fail("out of memory", 0);
  m.rgb->format = AV_PIX_FMT_RGB24;
  m.rgb->width = m.enc->width;
  m.rgb->height = m.enc->height;
  rc = av_frame_get_buffer(m.rgb, 0);
  if (rc < 0) m.fail("frame buffer", rc);
  // Every byte, the rows' padding too: the converter's vector loads read past the last pixel.
  std::memset(m.rgb->data[0], 0, static_cast<size_t>(m.rgb->linesize[0]) * static_cast<size_t>(m.rgb->height));
  m.frame->format = AV_PIX_FMT_YUV420P;
  m.frame->width = m.enc->width;
  m.frame->height = m.enc->height;
  rc = av_frame_get_buffer(m.frame, 0);
  if (rc < 0) m.fail("frame buffer", rc);
  m.sws = sws_getContext(m.enc->width, m.enc->height, AV_PIX_FMT_RGB24, m.enc->width, m.enc->height,
                         AV_PIX_FMT_YUV420P, SWS_BICUBIC | SWS_ACCURATE_RND | SWS_FULL_CHR_H_INP, nullptr, nullptr, nullptr);
  if (!m.sws) m.fail("no RGB to YUV converter", 0);
}

Mp4Writer::~Mp4Writer() = default;

void Mp4Writer::add_frame(const std::vector<uint8_t>& rgb) {
  Impl& m = *impl_;
  if (m.finished) throw std::logic_error(m.path + ": mp4 writer already finished");
  if (rgb.size() != size_t{m.width} * m.height * 3)
    throw std::invalid_argument(m.path + ": mp4 frame of " + std::to_string(rgb.size()) + " bytes, expected " +
                                std::to_string(size_t{m.width} * m.height * 3));
  for (uint32_t y = 0; y < m.height; ++y)
    std::memcpy(m.rgb->data[0] + static_cast<ptrdiff_t>(y) * m.rgb->linesize[0], rgb.data() + size_t{y} * m.width * 3,
                size_t{m.width} * 3);
  const int rc = av_frame_make_writable(m.frame);
  if (rc < 0) m.fail("frame not writable", rc);
  sws_scale(m.sws, m.rgb->data, m.rgb->linesize, 0, static_cast<int>(m.coded_h), m.frame->data, m.frame->linesize);
  m.frame->pts = static_cast<int64_t>(m.frames);
  m.encode(m.frame);
  ++m.frames;
}

void Mp4Writer::finish() {
  Impl& m = *impl_;
  if (m.finished) return;
  if (m.frames == 0) m.fail("no frame was written", 0);
  m.encode(nullptr);
  int rc = av_write_trailer(m.fmt);
  if (rc < 0) m.fail("write trailer", rc);
  rc = avio_closep(&m.fmt->pb);
  m.file_open = false;
  if (rc < 0) m.fail("close " + m.tmp, rc);
  std::error_code ec;
  std::filesystem::rename(m.tmp, m.path, ec);
  if (ec) m.fail("cannot rename " + m.tmp + " into place: " + ec.message(), 0);
  m.finished = true;
}

uint32_t Mp4Writer::width() const { return impl_->width; }
uint32_t Mp4Writer::height() const { return impl_->height; }
size_t Mp4Writer::frames() const { return impl_->frames; }

}  // namespace icube::video

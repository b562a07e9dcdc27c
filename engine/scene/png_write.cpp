// PNG writers: each path through the encoder measured fastest for it
// (bench/README.md, "PNG encoders"); see png_write.h.
#include "scene/png_write.h"

#include "scene/atomic_file.h"

#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wunused-function"
#pragma GCC diagnostic ignored "-Wdouble-promotion"
#pragma GCC diagnostic ignored "-Wshadow"
#pragma GCC diagnostic ignored "-Wconversion"
#pragma GCC diagnostic ignored "-Wsign-compare"
#pragma GCC diagnostic ignored "-Wcast-align"
#pragma GCC diagnostic ignored "-Wnull-dereference"
#pragma GCC diagnostic ignored "-Wimplicit-fallthrough"
#pragma GCC diagnostic ignored "-Wmissing-field-initializers"
#define STB_IMAGE_WRITE_STATIC
#define STB_IMAGE_WRITE_IMPLEMENTATION
#include <stb/stb_image_write.h>

#include <zlib.h>
#pragma GCC diagnostic pop

#include <spng.h>

#include <array>
#include <cstdlib>
#include <limits>
#include <stdexcept>
#include <vector>

namespace icube::scene {

namespace {

void check_size(int width, int height, int bytes_per_pixel) {
  if (width <= 0 || height <= 0)
    throw std::invalid_argument("png: image size " + std::to_string(width) + " x " + std::to_string(height) +
                                " must be positive");
  const uint64_t raw = (static_cast<uint64_t>(width) * static_cast<uint64_t>(bytes_per_pixel) + 1) *
                       static_cast<uint64_t>(height);
  if (raw > static_cast<uint64_t>(std::numeric_limits<int>::max() / 2))
    throw std::invalid_argument("png: image " + std::to_string(width) + " x " + std::to_string(height) +
                                " is too large to encode");
}

void append_to_string(void* context, void* data, int size) {
  static_cast<std::string*>(context)->append(static_cast<const char*>(data), static_cast<size_t>(size));
}

void put_be32(std::string& out, uint32_t v) {
  for (int shift = 24; shift >= 0; shift -= 8) out.push_back(static_cast<char>((v >> shift) & 0xFFu));
}

void put_chunk(std::string& out, const char type[4], const uint8_t* data, size_t n) {  // length, type, data, CRC-32
  put_be32(out, static_cast<uint32_t>(n));
  std::string body(type, 4);
  if (n) body.append(reinterpret_cast<const char*>(data), n);
  out += body;
  put_be32(out, static_cast<uint32_t>(::crc32(0L, reinterpret_cast<const Bytef*>(body.data()), static_cast<uInt>(body.size()))));
}

uint8_t paeth(int a, int b, int c) {
  const int p = a + b - c, pa = std::abs(p - a), pb = std::abs(p - b), pc = std::abs(p - c);
  return static_cast<uint8_t>(pa <= pb && pa <= pc ? a : pb <= pc ? b : c);
}

// 16-bit grey, PngSpeed::Fast: every row Paeth-filtered, zlib level 1, one IDAT. Kept beside libspng
// because it is measurably faster on this one path (bench/README.md, "PNG encoders": 1.65 against
// 2.75 ms for an 832 x 480 instance map at the same size).
std::string encode_gray16_paeth_fast(const uint16_t* samples, size_t w, size_t h) {
  const size_t stride = w * 2;
  std::vector<uint8_t> be(stride * h);  // PNG samples are big-endian
  for (size_t i = 0; i < w * h; ++i) {
    be[2 * i] = static_cast<uint8_t>(samples[i] >> 8);
    be[2 * i + 1] = static_cast<uint8_t>(samples[i] & 0xFFu);
  }
  std::vector<uint8_t> raw((stride + 1) * h);
  for (size_t y = 0; y < h; ++y) {
    const uint8_t* row = be.data() + y * stride;
    const uint8_t* prior = y ? row - stride : nullptr;
    uint8_t* out = &raw[y * (stride + 1)];
    out[0] = 4;  // Paeth
    for (size_t i = 0; i < stride; ++i) {
      const int a = i >= 2 ? row[i - 2] : 0, b = prior ? prior[i] : 0, c = prior && i >= 2 ? prior[i - 2] : 0;
      out[i + 1] = static_cast<uint8_t>(row[i] - paeth(a, b, c));
    }
  }
  std::string png("\x89PNG\r\n\x1a\n", 8);
  std::string ihdr;
  put_be32(ihdr, static_cast<uint32_t>(w));
  put_be32(ihdr, static_cast<uint32_t>(h));
  ihdr += std::string("\x10\x00\x00\x00\x00", 5);  // 16-bit grey, deflate, adaptive filtering, no interlace
  put_chunk(png, "IHDR", reinterpret_cast<const uint8_t*>(ihdr.data()), ihdr.size());
  uLongf zlen = compressBound(static_cast<uLong>(raw.size()));
  std::vector<uint8_t> z(zlen);
  if (compress2(z.data(), &zlen, raw.data(), static_cast<uLong>(raw.size()), 1) != Z_OK)
    throw std::runtime_error("png: zlib compression failed");
  put_chunk(png, "IDAT", z.data(), static_cast<size_t>(zlen));
  put_chunk(png, "IEND", nullptr, 0);
  return png;
}

// libspng: zlib `level`, the filters in `filters` (SPNG_FILTER_CHOICE_*), 8-bit samples or 16-bit ones
// in host order (libspng writes them big-endian).
std::string encode_spng(const void* samples, size_t bytes, int width, int height, uint8_t bit_depth, uint8_t colour_type,
                        int level, int filters) {
  spng_ctx* ctx = spng_ctx_new(SPNG_CTX_ENCODER);
  if (!ctx) throw std::runtime_error("png: out of memory");
  spng_set_option(ctx, SPNG_ENCODE_TO_BUFFER, 1);
  spng_set_option(ctx, SPNG_IMG_COMPRESSION_LEVEL, level);
  spng_set_option(ctx, SPNG_FILTER_CHOICE, filters);
  spng_ihdr ihdr{};
  ihdr.width = static_cast<uint32_t>(width);
  ihdr.height = static_cast<uint32_t>(height);
  ihdr.bit_depth = bit_depth;
  ihdr.color_type = colour_type;
  int err = spng_set_ihdr(ctx, &ihdr);
  if (!err) err = spng_encode_image(ctx, samples, bytes, SPNG_FMT_PNG, SPNG_ENCODE_FINALIZE);
  size_t len = 0;
  void* buf = err ? nullptr : spng_get_png_buffer(ctx, &len, &err);
  spng_ctx_free(ctx);
  if (!buf) throw std::runtime_error(std::string("png: libspng: ") + spng_strerror(err));
  std::string out(static_cast<const char*>(buf), len);
  std::free(buf);
  return out;
}

}  // namespace

std::string encode_png(const uint8_t* pixels, int width, int height, int channels, PngSpeed speed) {
  if (channels < 1 || channels > 4) throw std::invalid_argument("png: channels must be 1..4, got " + std::to_string(channels));
  check_size(width, height, channels);
  if (speed == PngSpeed::Fast) return encode_png_libspng(pixels, nullptr, width, height, channels, 1, SPNG_FILTER_CHOICE_PAETH);
  std::string out;
  if (!stbi_write_png_to_func(append_to_string, &out, width, height, channels, pixels, width * channels))
    throw std::runtime_error("png: stb_image_write failed to encode a " + std::to_string(width) + " x " +
                             std::to_string(height) + " image");
  return out;
}

std::string encode_png_gray16(const uint16_t* samples, int width, int height, PngSpeed speed) {
  check_size(width, height, 2);
  const size_t w = static_cast<size_t>(width), h = static_cast<size_t>(height);
  if (speed == PngSpeed::Fast) return encode_gray16_paeth_fast(samples, w, h);
  return encode_png_libspng(nullptr, samples, width, height, 1, 8, SPNG_FILTER_CHOICE_ALL);
}

std::string encode_png_libspng(const uint8_t* pixels, const uint16_t* gray16, int width, int height, int channels,
                               int zlib_level, int filter_choice) {
  static constexpr uint8_t kColourType[5] = {0, SPNG_COLOR_TYPE_GRAYSCALE, SPNG_COLOR_TYPE_GRAYSCALE_ALPHA,
                                             SPNG_COLOR_TYPE_TRUECOLOR, SPNG_COLOR_TYPE_TRUECOLOR_ALPHA};
  if (gray16) {
    check_size(width, height, 2);
    return encode_spng(gray16, static_cast<size_t>(width) * static_cast<size_t>(height) * 2, width, height, 16,
                       SPNG_COLOR_TYPE_GRAYSCALE, zlib_level, filter_choice);
  }
  if (channels < 1 || channels > 4) throw std::invalid_argument("png: channels must be 1..4, got " + std::to_string(channels));
  check_size(width, height, channels);
  const size_t bytes = static_cast<size_t>(width) * static_cast<size_t>(height) * static_cast<size_t>(channels);
  return encode_spng(pixels, bytes, width, height, 8, kColourType[channels], zlib_level, filter_choice);
}

void write_png(const std::string& path, const uint8_t* pixels, int width, int height, int channels) {
  write_file_atomic(path, encode_png(pixels, width, height, channels));
}

void write_png_gray16(const std::string& path, const uint16_t* samples, int width, int height) {
  write_file_atomic(path, encode_png_gray16(samples, width, height));
}

}  // namespace icube::scene

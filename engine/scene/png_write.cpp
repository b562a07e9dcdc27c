// PNG writers: 8-bit through stb_image_write, 16-bit grey through a small
// chunk writer (IHDR/IDAT/IEND, CRC-32) around stb's zlib compressor.
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

uint32_t crc32(const uint8_t* data, size_t n, uint32_t crc = 0) {
  static const std::array<uint32_t, 256> table = [] {
    std::array<uint32_t, 256> t{};
    for (uint32_t i = 0; i < 256; ++i) {
      uint32_t c = i;
      for (int k = 0; k < 8; ++k) c = (c & 1u) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
      t[i] = c;
    }
    return t;
  }();
  crc = ~crc;
  for (size_t i = 0; i < n; ++i) crc = table[(crc ^ data[i]) & 0xFFu] ^ (crc >> 8);
  return ~crc;
}

void put_be32(std::string& out, uint32_t v) {
  for (int shift = 24; shift >= 0; shift -= 8) out.push_back(static_cast<char>((v >> shift) & 0xFFu));
}

void put_chunk(std::string& out, const char type[4], const uint8_t* data, size_t n) {
  put_be32(out, static_cast<uint32_t>(n));
  std::string body(type, 4);
  if (n) body.append(reinterpret_cast<const char*>(data), n);
  out += body;
  put_be32(out, crc32(reinterpret_cast<const uint8_t*>(body.data()), body.size()));
}

uint8_t paeth(int a, int b, int c) {
  const int p = a + b - c, pa = std::abs(p - a), pb = std::abs(p - b), pc = std::abs(p - c);
  return static_cast<uint8_t>(pa <= pb && pa <= pc ? a : (pb <= pc ? b : c));
}

// Filters one row of `n` bytes with filter `type` (0-4), `bpp` bytes per pixel.
void filter_row(int type, const uint8_t* row, const uint8_t* prior, size_t n, size_t bpp, uint8_t* out) {
  for (size_t i = 0; i < n; ++i) {
    const int a = i >= bpp ? row[i - bpp] : 0, b = prior ? prior[i] : 0, c = (prior && i >= bpp) ? prior[i - bpp] : 0;
    int predicted = 0;
    switch (type) {
      case 1: predicted = a; break;
      case 2: predicted = b; break;
      case 3: predicted = (a + b) / 2; break;
      case 4: predicted = paeth(a, b, c); break;
      default: break;
    }
    out[i] = static_cast<uint8_t>(row[i] - predicted);
  }
}

// PNG from rows of `stride` bytes with `bpp` bytes per pixel: each row filtered with the filter
// that gives the smallest sum of |signed residuals| (the usual heuristic; Fast: Paeth), then zlib.
std::string encode_rows(const uint8_t* rows, size_t stride, size_t h, size_t bpp, int width, int height,
                        uint8_t bit_depth, uint8_t colour_type, PngSpeed speed) {
  std::vector<uint8_t> raw((stride + 1) * h), trial(stride), best(stride);
  for (size_t y = 0; y < h; ++y) {
    const uint8_t* row = rows + y * stride;
    const uint8_t* prior = y ? rows + (y - 1) * stride : nullptr;
    uint64_t best_cost = std::numeric_limits<uint64_t>::max();
    int best_type = 0;
    // Fast: Paeth alone (the best single filter for photographs; zero on flat masks).
    for (int type = speed == PngSpeed::Fast ? 4 : 0; type <= 4; ++type) {
      filter_row(type, row, prior, stride, bpp, trial.data());
      uint64_t cost = 0;
      for (uint8_t v : trial) cost += static_cast<uint64_t>(v < 128 ? v : 256 - v);
      if (cost < best_cost) best_cost = cost, best_type = type, best.swap(trial);
    }
    raw[y * (stride + 1)] = static_cast<uint8_t>(best_type);
    std::copy(best.begin(), best.end(), raw.begin() + static_cast<long>(y * (stride + 1) + 1));
  }
  std::string out("\x89PNG\r\n\x1a\n", 8);
  std::string ihdr;
  put_be32(ihdr, static_cast<uint32_t>(width));
  put_be32(ihdr, static_cast<uint32_t>(height));
  ihdr.push_back(static_cast<char>(bit_depth));
  ihdr.push_back(static_cast<char>(colour_type));
  ihdr += std::string("\x00\x00\x00", 3);  // deflate, adaptive filtering, no interlace
  put_chunk(out, "IHDR", reinterpret_cast<const uint8_t*>(ihdr.data()), ihdr.size());
  if (speed == PngSpeed::Fast) {
    uLongf zlen = compressBound(static_cast<uLong>(raw.size()));
    std::vector<uint8_t> z(zlen);
    if (compress2(z.data(), &zlen, raw.data(), static_cast<uLong>(raw.size()), 1) != Z_OK)
      throw std::runtime_error("png: zlib compression failed");
    put_chunk(out, "IDAT", z.data(), static_cast<size_t>(zlen));
  } else {
    int zlen = 0;
    unsigned char* z = stbi_zlib_compress(raw.data(), static_cast<int>(raw.size()), &zlen, 8);
    if (!z) throw std::runtime_error("png: zlib compression failed");
    put_chunk(out, "IDAT", z, static_cast<size_t>(zlen));
    std::free(z);
  }
  put_chunk(out, "IEND", nullptr, 0);
  return out;
}

}  // namespace

std::string encode_png(const uint8_t* pixels, int width, int height, int channels, PngSpeed speed) {
  if (channels < 1 || channels > 4) throw std::invalid_argument("png: channels must be 1..4, got " + std::to_string(channels));
  check_size(width, height, channels);
  if (speed == PngSpeed::Fast) {
    static constexpr uint8_t kColourType[5] = {0, 0, 4, 2, 6};  // grey, grey+alpha, RGB, RGBA
    const size_t stride = static_cast<size_t>(width) * static_cast<size_t>(channels);
    return encode_rows(pixels, stride, static_cast<size_t>(height), static_cast<size_t>(channels), width, height, 8,
                       kColourType[channels], speed);
  }
  std::string out;
  if (!stbi_write_png_to_func(append_to_string, &out, width, height, channels, pixels, width * channels))
    throw std::runtime_error("png: stb_image_write failed to encode a " + std::to_string(width) + " x " +
                             std::to_string(height) + " image");
  return out;
}

std::string encode_png_gray16(const uint16_t* samples, int width, int height, PngSpeed speed) {
  check_size(width, height, 2);
  const size_t w = static_cast<size_t>(width), h = static_cast<size_t>(height), stride = w * 2;
  std::vector<uint8_t> be(stride * h);  // PNG samples are big-endian
  for (size_t i = 0; i < w * h; ++i) {
    be[2 * i] = static_cast<uint8_t>(samples[i] >> 8);
    be[2 * i + 1] = static_cast<uint8_t>(samples[i] & 0xFFu);
  }
  return encode_rows(be.data(), stride, h, 2, width, height, 16, 0, speed);
}

void write_png(const std::string& path, const uint8_t* pixels, int width, int height, int channels) {
  write_file_atomic(path, encode_png(pixels, width, height, channels));
}

void write_png_gray16(const std::string& path, const uint16_t* samples, int width, int height) {
  write_file_atomic(path, encode_png_gray16(samples, width, height));
}

}  // namespace icube::scene

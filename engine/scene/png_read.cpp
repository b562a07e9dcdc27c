// PNG decoding; see png_read.h. stb_image's own warnings are silenced.
#include "scene/png_read.h"

#include <cerrno>
#include <cstring>
#include <fstream>
#include <iterator>
#include <stdexcept>

#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wpragmas"
#pragma GCC diagnostic ignored "-Wunknown-warning-option"
#pragma GCC diagnostic ignored "-Wunused-function"
#pragma GCC diagnostic ignored "-Wdouble-promotion"
#pragma GCC diagnostic ignored "-Wshadow"
#pragma GCC diagnostic ignored "-Wcast-align"
#pragma GCC diagnostic ignored "-Wnull-dereference"
#pragma GCC diagnostic ignored "-Wimplicit-fallthrough"
#pragma GCC diagnostic ignored "-Wsign-compare"
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#pragma GCC diagnostic ignored "-Wconversion"
#pragma GCC diagnostic ignored "-Wsign-conversion"
#pragma GCC diagnostic ignored "-Wold-style-cast"
#pragma GCC diagnostic ignored "-Wuseless-cast"
#define STB_IMAGE_STATIC
#define STB_IMAGE_IMPLEMENTATION
#define STBI_ONLY_PNG
#include <stb/stb_image.h>
#pragma GCC diagnostic pop

namespace icube::scene {

std::string png_problem(std::string_view b) {
  static const unsigned char kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
  if (b.empty()) return "the file is empty";
  if (b.size() < 8 || std::memcmp(b.data(), kSignature, 8) != 0) return "not a PNG file (no PNG signature at byte 0)";
  auto be32 = [&](size_t at) {
    const auto* u = reinterpret_cast<const unsigned char*>(b.data() + at);
    return (uint64_t{u[0]} << 24) | (uint64_t{u[1]} << 16) | (uint64_t{u[2]} << 8) | uint64_t{u[3]};
  };
  size_t at = 8;
  bool header = false, data = false;
  std::string last = "the signature";
  while (at < b.size()) {
    if (b.size() - at < 8)
      return "truncated: " + std::to_string(b.size()) + " bytes end inside a chunk header at byte " + std::to_string(at) +
             ", after " + last;
    const uint64_t len = be32(at);
    const std::string type(b.substr(at + 4, 4));
    if (at == 8 && type != "IHDR") return "the first chunk is '" + type + "', not IHDR (byte 8)";
    if (len > 0x7FFFFFFFu) return "chunk " + type + " at byte " + std::to_string(at) + " has an invalid length " + std::to_string(len);
    if (b.size() - at - 8 < len + 4)
      return "truncated: the file ends inside chunk " + type + " at byte " + std::to_string(at) + " (" +
             std::to_string(len) + " data bytes + CRC announced, " + std::to_string(b.size() - at - 8) + " present)";
    header = header || type == "IHDR";
    data = data || type == "IDAT";
    if (type == "IEND") return data ? "the image data (IDAT) is corrupt or too short for the IHDR size"
                                    : "no image data: IEND at byte " + std::to_string(at) + " before any IDAT chunk";
    last = "chunk " + type + " at byte " + std::to_string(at);
    at += 12 + len;
  }
  if (!header) return "truncated: no IHDR chunk";
  return std::string("truncated: the file ends after ") + last + (data ? " without IEND" : ", before any image data (IDAT)");
}

namespace {
[[noreturn]] void fail(const std::string& name, std::string_view bytes) {
  const char* why = stbi_failure_reason();
  std::string what = png_problem(bytes);
  if (why && *why && what.find("corrupt") != std::string::npos) what += std::string(" (") + why + ")";
  throw std::runtime_error(name + ": cannot read PNG: " + what);
}
}  // namespace

Image8 read_png(const std::string& path, int channels) {
  if (channels < 1 || channels > 4) throw std::invalid_argument("read_png: channels must be 1..4");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(path + ": cannot open (" + std::strerror(errno) + ")");
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (bytes.size() > 0x7FFFFFFFu) throw std::runtime_error(path + ": cannot read PNG: larger than 2 GiB");
  int w = 0, h = 0, n = 0;
  uint8_t* data = stbi_load_from_memory(reinterpret_cast<const stbi_uc*>(bytes.data()), static_cast<int>(bytes.size()),
                                        &w, &h, &n, channels);
  if (!data) fail(path, bytes);
  Image8 img;
  img.width = w;
  img.height = h;
  img.channels = channels;
  img.pixels.assign(data, data + static_cast<size_t>(w) * static_cast<size_t>(h) * static_cast<size_t>(channels));
  stbi_image_free(data);
  return img;
}

std::vector<uint16_t> decode_png_gray16(std::string_view bytes, const std::string& name, int* width, int* height) {
  int w = 0, h = 0, n = 0;
  uint16_t* data = stbi_load_16_from_memory(reinterpret_cast<const stbi_uc*>(bytes.data()), static_cast<int>(bytes.size()),
                                            &w, &h, &n, 1);
  if (!data) fail(name, bytes);
  std::vector<uint16_t> out(data, data + static_cast<size_t>(w) * static_cast<size_t>(h));
  stbi_image_free(data);
  *width = w;
  *height = h;
  return out;
}

}  // namespace icube::scene

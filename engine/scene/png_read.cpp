// PNG decoding; see png_read.h. stb_image's own warnings are silenced.
#include "scene/png_read.h"

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

Image8 read_png(const std::string& path, int channels) {
  if (channels < 1 || channels > 4) throw std::invalid_argument("read_png: channels must be 1..4");
  int w = 0, h = 0, n = 0;
  uint8_t* data = stbi_load(path.c_str(), &w, &h, &n, channels);
  if (!data) {
    const char* why = stbi_failure_reason();
    throw std::runtime_error(path + ": cannot read PNG (" + (why ? why : "unknown error") + ")");
  }
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
  if (!data) {
    const char* why = stbi_failure_reason();
    throw std::runtime_error(name + ": cannot read PNG (" + (why ? why : "unknown error") + ")");
  }
  std::vector<uint16_t> out(data, data + static_cast<size_t>(w) * static_cast<size_t>(h));
  stbi_image_free(data);
  *width = w;
  *height = h;
  return out;
}

}  // namespace icube::scene

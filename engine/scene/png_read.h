// PNG decoding (stb_image, PNG only): the viewer's checks and the splat sky
// panoramas. The counterpart of png_write.h.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace icube::scene {

struct Image8 {
  int width = 0, height = 0, channels = 0;  // channels as requested
  std::vector<uint8_t> pixels;              // rows tightly packed
};

// Decodes `path` to `channels` channels (1-4). Throws std::runtime_error "PATH: cannot read PNG:
// what is wrong" (png_problem).
Image8 read_png(const std::string& path, int channels);

// Decodes PNG bytes (8- or 16-bit) to one 16-bit channel; `name` labels errors ("NAME: reason").
std::vector<uint16_t> decode_png_gray16(std::string_view bytes, const std::string& name, int* width, int* height);

// What is wrong with PNG bytes that do not decode, in words: empty, no signature, truncated
// inside or after which chunk (with byte offsets), no image data, or corrupt image data.
std::string png_problem(std::string_view bytes);

}  // namespace icube::scene

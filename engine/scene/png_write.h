// PNG encoding to memory and atomic PNG files (formats.md §10).
//
// 8-bit images (grey, grey+alpha, RGB, RGBA) go through stb_image_write.
// 16-bit grey (depth in cm, instance ids) and PngSpeed::Fast have their own
// small encoder (stb_image_write only writes 8-bit samples, slowly): samples are stored big-endian as
// PNG requires (colour type 0, bit depth 16), rows filtered adaptively, and
// compressed with stb's zlib. No gamma/sRGB chunks are written, so data PNGs
// read back exactly.
#pragma once

#include <cstdint>
#include <string>

namespace icube::scene {

// Small: stb's encoder (its zlib at level 8). Fast: Paeth-filtered rows and zlib's deflate at
// level 1 (on an 832 x 480 frame ~4x faster than Small and ~20 % smaller: stb's deflate is weak), for frames written while the next
// renders (icube frames render). Both decode to the same pixels.
enum class PngSpeed { Small, Fast };

// Rows are tightly packed (width · channels bytes); channels 1-4.
// Throws std::invalid_argument for a bad size or channel count.
std::string encode_png(const uint8_t* pixels, int width, int height, int channels, PngSpeed speed = PngSpeed::Small);
// Host-order uint16 samples, one per pixel.
std::string encode_png_gray16(const uint16_t* samples, int width, int height, PngSpeed speed = PngSpeed::Small);

// encode_*, then write_file_atomic(path, ...).
void write_png(const std::string& path, const uint8_t* pixels, int width, int height, int channels);
void write_png_gray16(const std::string& path, const uint16_t* samples, int width, int height);

}  // namespace icube::scene

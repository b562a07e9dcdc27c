// PNG encoding to memory and atomic PNG files (formats.md §10).
//
// Each path goes through the encoder measured fastest for it on the package's
// images (icube-bench-png, bench/README.md "PNG encoders"; every candidate
// decodes to the same pixels):
//   8-bit Small   stb_image_write (its zlib; faster than libspng at zlib 6-8, files ~40 % larger)
//   8-bit Fast    libspng, zlib 1, Paeth (1.4x faster than our own Paeth + zlib 1, same size)
//   16-bit Small  libspng, zlib 8, adaptive filters (1.7x faster than our filter + stb zlib, 1/6 the size)
//   16-bit Fast   our own Paeth rows + zlib 1 (1.7x faster than libspng's at the same size: the
//                 one path where the hand-written encoder is kept)
// 16-bit samples are written big-endian as PNG requires (grey, bit depth 16).
// No gamma/sRGB chunks are written, so data PNGs read back exactly.
#pragma once

#include <cstdint>
#include <string>

namespace icube::scene {

// Small: the smaller files (Stage 2's buffers, sheets). Fast: Paeth rows at zlib level 1, for frames
// written while the next renders (icube frames render). Both decode to the same pixels.
enum class PngSpeed { Small, Fast };

// Rows are tightly packed (width · channels bytes); channels 1-4.
// Throws std::invalid_argument for a bad size or channel count.
std::string encode_png(const uint8_t* pixels, int width, int height, int channels, PngSpeed speed = PngSpeed::Small);
// Host-order uint16 samples, one per pixel.
std::string encode_png_gray16(const uint16_t* samples, int width, int height, PngSpeed speed = PngSpeed::Small);

// libspng at an explicit zlib level (0-9) and filter choice (spng.h's SPNG_FILTER_CHOICE_* bits): 8-bit
// samples (channels 1-4), or 16-bit grey when `gray16` is given (host order). The paths above use it
// where it was measured fastest; icube-bench-png compares it at other settings.
std::string encode_png_libspng(const uint8_t* pixels, const uint16_t* gray16, int width, int height, int channels,
                               int zlib_level, int filter_choice);

// encode_*, then write_file_atomic(path, ...).
void write_png(const std::string& path, const uint8_t* pixels, int width, int height, int channels);
void write_png_gray16(const std::string& path, const uint16_t* samples, int width, int height);

}  // namespace icube::scene

// The antimatter15 `.splat` format (../shared/reference/splatting.md §4.2):
// no header, 32 bytes per Gaussian, little endian:
//
//   bytes  0–11  float32 x, y, z
//   bytes 12–23  float32 scale_0..2, already activated (σ = exp(raw), metres)
//   bytes 24–27  uint8 R, G, B, A: RGB = clamp(round((0.5 + C0·f_dc)·255)),
//                A = clamp(round(sigmoid(opacity)·255))
//   bytes 28–31  uint8 rotation = clamp(round(q̂·128 + 128)), order w, x, y, z
//
// Reading gives SH degree 0: f_dc = (rgb/255 − 0.5)/C0, opacity = A/255,
// q = normalize((b − 128)/128). Writing keeps only the DC term of clouds with
// SH degree 1–3 (view dependence is lost; `dropped_sh` tells the caller) and
// sorts by −σ0·σ1·σ2·opacity like the reference converter (largest, most
// opaque Gaussians first, for progressive loading), unless asked not to.
// Positions are stored as float32: scenes far from the origin lose precision
// (ulp 8 mm at 100 km).
//
// Reading rejects, with one line naming the file and the Gaussian
// (scene::InputError): a size that is not a multiple of 32 bytes (truncated or
// not a .splat file), NaN/Inf positions or scales, scales <= 0, and rotation
// bytes that decode to the zero quaternion (all four 128).
// Tests: tests/splat/test_splat_io.cpp.
#pragma once

#include "splat/gaussians.h"

#include <string>
#include <string_view>

namespace icube::splat {

inline constexpr size_t kSplatRecordBytes = 32;

struct SplatWriteOptions {
  bool sort_by_importance = true;  // −σ0·σ1·σ2·opacity ascending, stable
};

GaussianCloud gaussians_from_splat_bytes(std::string_view bytes, const std::string& name);
GaussianCloud read_gaussians_splat(const std::string& path);

// `dropped_sh` (optional) is set when SH coefficients above degree 0 were discarded.
std::string gaussians_to_splat_bytes(const GaussianCloud& cloud, const SplatWriteOptions& opts = {},
                                     bool* dropped_sh = nullptr);
void write_gaussians_splat(const std::string& path, const GaussianCloud& cloud, const SplatWriteOptions& opts = {},
                           bool* dropped_sh = nullptr);

// A Gaussian file by content: "ply\n" magic → 3DGS .ply, otherwise a name ending in
// ".splat" → .splat; anything else is an InputError naming the file.
GaussianCloud read_gaussians(const std::string& path);
GaussianCloud gaussians_from_bytes(std::string_view bytes, const std::string& path);
bool is_ply_bytes(std::string_view bytes);
bool has_splat_extension(const std::string& path);
// By extension of `path`: ".ply" or ".splat" (case-insensitive); anything else throws
// std::invalid_argument naming the path.
void write_gaussians(const std::string& path, const GaussianCloud& cloud, bool* dropped_sh = nullptr);

}  // namespace icube::splat

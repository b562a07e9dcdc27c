// The coordinate guidance buffer (conventions §10.3).
//
// Points: p = z · K^-1 [u + o, v + o, 1] (o = 0 InfiniCube integer pixels, 0.5
// pixel centres; z = z-depth), moved into the FIRST rendered camera's OpenCV
// frame with inv(pose_0) · pose_i (double). Pixels with z = 0 (no depth run)
// are invalid.
// Range: up to 100,000 valid pixels drawn without replacement over all frames
// (Floyd's algorithm on std::mt19937_64(seed), index = next() % n; all of them
// when there are fewer), per axis min = 5 % and max = 95 % quantile (numpy's
// default 'linear' interpolation at q·(n-1)), range = max(max - min, 1e-7).
// Encoding: p' = clamp(2 (p - min) / range - 1, -1, 1), value = (p' + 1) / 2,
// × 255 truncated; invalid pixels (sky) are (255, 255, 255).
#pragma once

#include "render/camera.h"

#include <glm/glm.hpp>

#include <cstdint>
#include <vector>

namespace icube::render {

inline constexpr size_t kCoordinateSamples = 100000;
inline constexpr double kCoordinateLowQuantile = 0.05, kCoordinateHighQuantile = 0.95;
inline constexpr double kCoordinateMinRange = 1e-7;

// Row-major W·H points (x, y, z interleaved, float32) of one frame; invalid pixels are 0.
// `rel` = inv(pose_0) · pose_i (OpenCV camera-to-camera-0).
std::vector<float> coordinate_points(const PinholeIntrinsics& K, const std::vector<float>& zdepth,
                                     const glm::dmat4& rel, PixelConvention pixels);

// numpy.quantile(values, q) with linear interpolation; `values` is reordered. Empty -> 0.
double quantile_linear(std::vector<double>& values, double q);

struct CoordinateRange {
  glm::dvec3 min{0.0};
  glm::dvec3 range{1.0};
  size_t samples = 0;  // valid points the quantiles came from
};

// One point of coordinate_points (pixel i of an image of width K.width), in double.
glm::dvec3 coordinate_point(const PinholeIntrinsics& K, size_t i, double z, const glm::dmat4& rel, PixelConvention pixels);

// Quantile range over sampled valid points of all frames: zdepth[f] is frame
// f's z-depth (W·H), rel[f] its inv(pose_0) · pose_f. Points are computed for
// the sampled pixels only.
CoordinateRange coordinate_range(const PinholeIntrinsics& K, const std::vector<const std::vector<float>*>& zdepth,
                                 const std::vector<glm::dmat4>& rel, PixelConvention pixels, uint64_t seed,
                                 size_t max_samples = kCoordinateSamples);
// The same from already chosen points (all used).
CoordinateRange coordinate_range_of(const std::vector<glm::dvec3>& points);

// Row-major RGB8 (W·H·3).
std::vector<uint8_t> encode_coordinates(const std::vector<float>& points, const std::vector<float>& zdepth,
                                        const CoordinateRange& r);

}  // namespace icube::render

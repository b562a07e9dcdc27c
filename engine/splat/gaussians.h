// 3D Gaussian splatting scenes: the in-memory Gaussian set and its 3DGS .ply
// reader/writer (../shared/reference/splatting.md §4.1, formats.md §6).
//
// Values are stored *activated*: opacity = sigmoid(raw), scale = exp(raw) (σ
// along the local axes), rotation = normalize(rot_0..3) with rot_0 = w.
// Positions are double (metres) so scenes far from the origin keep their
// precision until the renderer subtracts the camera position.
// SH coefficients are raw (f_dc and f_rest), Gaussian-major, then coefficient
// (m = -l..l within degree l), then channel: sh[(g·K + k)·3 + c], K = (d+1)².
//
// The reader accepts ascii and binary_little_endian, any SH degree 0–3
// (f_rest count 0, 9, 24 or 45, sorted by numeric suffix), extra properties
// (normals, filter_3D, ...) and trailing bytes after the declared data. It
// rejects NaN/Inf values and zero quaternions with one line naming the file
// and the vertex (scene::InputError). The writer emits Inria's layout
// (binary_little_endian, all float: x y z nx ny nz f_dc_0..2 f_rest_* opacity
// scale_0..2 rot_0..3), which SuperSplat and the reference viewers open.
// Tests: tests/splat/test_splat_io.cpp.
#pragma once

#include <glm/glm.hpp>

#include <array>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace icube::splat {

inline constexpr double kShC0 = 0.28209479177387814;

struct GaussianCloud {
  uint32_t sh_degree = 0;
  std::vector<glm::dvec3> positions;
  std::vector<glm::vec3> scales;     // σ, activated (exp)
  std::vector<glm::vec4> rotations;  // unit quaternion (w, x, y, z)
  std::vector<float> opacities;      // activated (sigmoid)
  std::vector<float> sh;             // size() · sh_coeffs() · 3 raw coefficients

  size_t size() const { return positions.size(); }
  uint32_t sh_coeffs() const { return (sh_degree + 1) * (sh_degree + 1); }
  // Appends one Gaussian; `coeffs` holds sh_coeffs()·3 values (k-major, then RGB).
  void add(const glm::dvec3& p, const glm::vec3& scale, const glm::vec4& q_wxyz, float opacity, const float* coeffs);
  // Throws std::invalid_argument when array sizes disagree or a value is non-finite / a quaternion not unit.
  void validate() const;
};

// Σ = R(q)·diag(s²)·R(q)ᵀ as [00, 01, 02, 11, 12, 22], computed in double and rounded to float
// (shared by the CPU reference and the GPU upload so both see the same covariance).
std::array<float, 6> covariance3d(const glm::vec3& scale, const glm::vec4& q_wxyz);

// `name` is used in error messages only.
GaussianCloud gaussians_from_ply_bytes(std::string_view bytes, const std::string& name);
GaussianCloud read_gaussians_ply(const std::string& path);
std::string gaussians_to_ply_bytes(const GaussianCloud& cloud);
void write_gaussians_ply(const std::string& path, const GaussianCloud& cloud);

struct CloudSummary {
  size_t count = 0;
  uint32_t sh_degree = 0;
  glm::dvec3 min{0.0}, max{0.0}, centroid{0.0};
  double opacity_min = 0, opacity_mean = 0, opacity_max = 0;
  double scale_min = 0, scale_median = 0, scale_max = 0;  // over all axes
};
CloudSummary summarize(const GaussianCloud& cloud);

}  // namespace icube::splat

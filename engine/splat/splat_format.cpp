// antimatter15 .splat reader/writer; see splat_format.h.
#include "splat/splat_format.h"

#include "scene/atomic_file.h"
#include "scene/input_error.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <numeric>
#include <stdexcept>

namespace icube::splat {

namespace {

float get_f32(const char* p) {
  float v;
  std::memcpy(&v, p, 4);  // little-endian hosts only (x86-64, aarch64)
  return v;
}

void put_f32(char* p, float v) { std::memcpy(p, &v, 4); }

uint8_t quantise(double v) { return static_cast<uint8_t>(std::clamp<long>(std::lround(v), 0, 255)); }

std::string lower_extension(const std::string& path) {
  const size_t slash = path.find_last_of("/\\");
  const size_t dot = path.find_last_of('.');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return "";
  std::string e = path.substr(dot);
  for (char& c : e) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return e;
}

}  // namespace

GaussianCloud gaussians_from_splat_bytes(std::string_view bytes, const std::string& name) {
  if (bytes.size() % kSplatRecordBytes != 0)
    throw scene::InputError(name, "size", std::to_string(bytes.size()) + " bytes is not a multiple of 32 (truncated, or not a .splat file)");
  const size_t n = bytes.size() / kSplatRecordBytes;
  GaussianCloud cloud;
  cloud.sh_degree = 0;
  cloud.positions.reserve(n);
  cloud.scales.reserve(n);
  cloud.rotations.reserve(n);
  cloud.opacities.reserve(n);
  cloud.sh.reserve(n * 3);
  static const char* kAxis[3] = {"x", "y", "z"};
  for (size_t i = 0; i < n; ++i) {
    const char* r = bytes.data() + i * kSplatRecordBytes;
    const std::string where = "Gaussian " + std::to_string(i) + " (byte " + std::to_string(i * kSplatRecordBytes) + ")";
    glm::dvec3 p;
    glm::vec3 s;
    for (int k = 0; k < 3; ++k) {
      const float v = get_f32(r + 4 * k);
      if (!std::isfinite(v))
        throw scene::InputError(name, where, std::string("position ") + kAxis[k] + " is " + (std::isnan(v) ? "NaN" : "infinite"));
      p[k] = v;
    }
    for (int k = 0; k < 3; ++k) {
      const float v = get_f32(r + 12 + 4 * k);
      if (!std::isfinite(v))
        throw scene::InputError(name, where, "scale_" + std::to_string(k) + " is " + (std::isnan(v) ? "NaN" : "infinite"));
      if (!(v > 0.0f)) throw scene::InputError(name, where, "scale_" + std::to_string(k) + " = " + std::to_string(v) + " is not positive");
      s[k] = v;
    }
    const auto* u = reinterpret_cast<const unsigned char*>(r + 24);
    float coeffs[3];
    for (int c = 0; c < 3; ++c) coeffs[c] = static_cast<float>((u[c] / 255.0 - 0.5) / kShC0);
    const float opacity = static_cast<float>(u[3] / 255.0);
    double q[4], qn = 0.0;
    for (int k = 0; k < 4; ++k) {
      q[k] = (u[4 + k] - 128.0) / 128.0;
      qn += q[k] * q[k];
    }
    if (!(qn > 0.0)) throw scene::InputError(name, where, "rotation bytes decode to the zero quaternion");
    qn = std::sqrt(qn);
    cloud.add(p, s, glm::vec4(q[0] / qn, q[1] / qn, q[2] / qn, q[3] / qn), opacity, coeffs);
  }
  return cloud;
}

GaussianCloud read_gaussians_splat(const std::string& path) {
  return gaussians_from_splat_bytes(scene::read_file(path), path);
}

std::string gaussians_to_splat_bytes(const GaussianCloud& cloud, const SplatWriteOptions& opts, bool* dropped_sh) {
  cloud.validate();
  const size_t n = cloud.size();
  const uint32_t K = cloud.sh_coeffs();
  if (dropped_sh) *dropped_sh = cloud.sh_degree > 0 && n > 0;
  std::vector<size_t> order(n);
  std::iota(order.begin(), order.end(), size_t{0});
  if (opts.sort_by_importance) {
    std::vector<double> key(n);
    for (size_t i = 0; i < n; ++i) {
      const glm::dvec3 s(cloud.scales[i]);
      key[i] = -s.x * s.y * s.z * static_cast<double>(cloud.opacities[i]);
    }
    std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) { return key[a] < key[b]; });
  }
  std::string out(n * kSplatRecordBytes, '\0');
  for (size_t j = 0; j < n; ++j) {
    const size_t i = order[j];
    char* r = out.data() + j * kSplatRecordBytes;
    for (int k = 0; k < 3; ++k) {
      const float v = static_cast<float>(cloud.positions[i][k]);
      if (!std::isfinite(v))
        throw std::invalid_argument("splat: Gaussian " + std::to_string(i) + " position does not fit float32");
      put_f32(r + 4 * k, v);
    }
    for (int k = 0; k < 3; ++k) put_f32(r + 12 + 4 * k, cloud.scales[i][k]);
    auto* u = reinterpret_cast<unsigned char*>(r + 24);
    const float* c = &cloud.sh[i * K * 3];
    for (int ch = 0; ch < 3; ++ch) u[ch] = quantise((0.5 + kShC0 * static_cast<double>(c[ch])) * 255.0);
    u[3] = quantise(static_cast<double>(cloud.opacities[i]) * 255.0);
    const glm::dvec4 q = glm::normalize(glm::dvec4(cloud.rotations[i]));
    for (int k = 0; k < 4; ++k) u[4 + k] = quantise(q[k] * 128.0 + 128.0);
  }
  return out;
}

void write_gaussians_splat(const std::string& path, const GaussianCloud& cloud, const SplatWriteOptions& opts,
                           bool* dropped_sh) {
  scene::write_file_atomic(path, gaussians_to_splat_bytes(cloud, opts, dropped_sh));
}

bool is_ply_bytes(std::string_view bytes) { return bytes.starts_with("ply\n") || bytes.starts_with("ply\r\n"); }

bool has_splat_extension(const std::string& path) { return lower_extension(path) == ".splat"; }

GaussianCloud read_gaussians(const std::string& path) { return gaussians_from_bytes(scene::read_file(path), path); }

GaussianCloud gaussians_from_bytes(std::string_view bytes, const std::string& path) {
  if (is_ply_bytes(bytes)) return gaussians_from_ply_bytes(bytes, path);
  if (lower_extension(path) == ".splat") return gaussians_from_splat_bytes(bytes, path);
  if (lower_extension(path) == ".ply") return gaussians_from_ply_bytes(bytes, path);  // names the bad magic
  throw scene::InputError(path, "", "not a Gaussian file (expected a 3DGS .ply starting with 'ply' or a .splat file)");
}

void write_gaussians(const std::string& path, const GaussianCloud& cloud, bool* dropped_sh) {
  const std::string e = lower_extension(path);
  if (dropped_sh) *dropped_sh = false;
  if (e == ".ply") write_gaussians_ply(path, cloud);
  else if (e == ".splat") write_gaussians_splat(path, cloud, {}, dropped_sh);
  else throw std::invalid_argument(path + ": output must end in .ply or .splat");
}

}  // namespace icube::splat

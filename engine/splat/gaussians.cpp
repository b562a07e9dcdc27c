// 3DGS .ply reader/writer and the Gaussian set; see gaussians.h.
#include "splat/gaussians.h"

#include "scene/atomic_file.h"
#include "scene/input_error.h"
#include "world/ply_reader.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <sstream>
#include <stdexcept>

namespace icube::splat {

namespace {

using world::PlyCursor;
using world::PlyElement;
using world::PlyFormat;
using world::PlyHeader;
using world::PlyType;

std::string vertex_where(uint64_t row) { return "vertex " + std::to_string(row); }

double next_value(PlyCursor& in, PlyType t, const std::string& name, uint64_t row, const std::string& element) {
  double v = 0.0;
  switch (in.next(t, v)) {
    case PlyCursor::Status::Ok: return v;
    case PlyCursor::Status::End:
      throw scene::InputError(name, element + " " + std::to_string(row), "file ends inside the element data");
    case PlyCursor::Status::BadInteger:
    case PlyCursor::Status::BadNumber: break;
  }
  throw scene::InputError(name, element + " " + std::to_string(row), "'" + std::string(in.token()) + "' is not a number");
}

void read_row(PlyCursor& in, const PlyElement& e, std::vector<double>& vals, const std::string& name, uint64_t row) {
  for (size_t k = 0; k < e.props.size(); ++k) {
    const auto& p = e.props[k];
    if (!p.is_list) {
      vals[k] = next_value(in, p.type, name, row, e.name);
      continue;
    }
    const double n = next_value(in, p.count_type, name, row, e.name);
    if (!(n >= 0.0) || n > 1e9) throw scene::InputError(name, e.name + " " + std::to_string(row), "bad list length");
    for (uint64_t j = 0; j < static_cast<uint64_t>(n); ++j) (void)next_value(in, p.type, name, row, e.name);
    vals[k] = 0.0;
  }
}

// Column of a scalar property, or -1.
int column(const PlyElement& v, const std::string& prop) { return v.scalar_index(prop); }

int required(const PlyElement& v, const std::string& prop, const std::string& name) {
  const int c = column(v, prop);
  if (c < 0) throw scene::InputError(name, "header", "vertex element lacks property '" + prop + "'");
  return c;
}

double sigmoid(double x) { return x >= 0 ? 1.0 / (1.0 + std::exp(-x)) : std::exp(x) / (1.0 + std::exp(x)); }

void put_f32(std::string& out, float v) {
  char b[4];
  std::memcpy(b, &v, 4);  // little-endian hosts only (x86-64, aarch64)
  out.append(b, 4);
}

}  // namespace

void GaussianCloud::add(const glm::dvec3& p, const glm::vec3& scale, const glm::vec4& q, float opacity,
                        const float* coeffs) {
  positions.push_back(p);
  scales.push_back(scale);
  rotations.push_back(q);
  opacities.push_back(opacity);
  sh.insert(sh.end(), coeffs, coeffs + sh_coeffs() * 3);
}

void GaussianCloud::validate() const {
  const size_t n = size();
  if (sh_degree > 3) throw std::invalid_argument("gaussians: SH degree above 3");
  if (scales.size() != n || rotations.size() != n || opacities.size() != n || sh.size() != n * sh_coeffs() * 3)
    throw std::invalid_argument("gaussians: array sizes disagree");
  for (size_t i = 0; i < n; ++i) {
    const auto& p = positions[i];
    const auto& s = scales[i];
    const auto& q = rotations[i];
    const bool finite = std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z) && std::isfinite(s.x) &&
                        std::isfinite(s.y) && std::isfinite(s.z) && std::isfinite(opacities[i]);
    if (!finite) throw std::invalid_argument("gaussians: Gaussian " + std::to_string(i) + " has a non-finite value");
    const glm::dvec4 qd(q);
    const double qn = std::sqrt(glm::dot(qd, qd));
    if (!(std::fabs(qn - 1.0) < 1e-3))
      throw std::invalid_argument("gaussians: Gaussian " + std::to_string(i) + " has a non-unit quaternion");
  }
  for (float v : sh)
    if (!std::isfinite(v)) throw std::invalid_argument("gaussians: non-finite SH coefficient");
}

std::array<float, 6> covariance3d(const glm::vec3& scale, const glm::vec4& q) {
  const double r = q.x, x = q.y, y = q.z, z = q.w;  // vec4 holds (w, x, y, z) in x..w
  const double R[3][3] = {{1 - 2 * (y * y + z * z), 2 * (x * y - r * z), 2 * (x * z + r * y)},
                          {2 * (x * y + r * z), 1 - 2 * (x * x + z * z), 2 * (y * z - r * x)},
                          {2 * (x * z - r * y), 2 * (y * z + r * x), 1 - 2 * (x * x + y * y)}};
  const glm::dvec3 sd(scale);
  const double s2[3] = {sd.x * sd.x, sd.y * sd.y, sd.z * sd.z};
  auto c = [&](int a, int b) { return R[a][0] * s2[0] * R[b][0] + R[a][1] * s2[1] * R[b][1] + R[a][2] * s2[2] * R[b][2]; };
  return {float(c(0, 0)), float(c(0, 1)), float(c(0, 2)), float(c(1, 1)), float(c(1, 2)), float(c(2, 2))};
}

GaussianCloud gaussians_from_ply_bytes(std::string_view bytes, const std::string& name) {
  const PlyHeader h = world::parse_ply_header(bytes, name);
  if (h.format == PlyFormat::BinaryBE)
    throw scene::InputError(name, "header line " + std::to_string(h.format_line),
                            "format 'binary_big_endian' is not supported (ascii or binary_little_endian)");
  const PlyElement* vertex = h.find("vertex");
  if (!vertex) throw scene::InputError(name, "header", "no 'vertex' element");
  const int cx = required(*vertex, "x", name), cy = required(*vertex, "y", name), cz = required(*vertex, "z", name);
  int dc[3], sc[3], rot[4];
  for (int k = 0; k < 3; ++k) dc[k] = required(*vertex, "f_dc_" + std::to_string(k), name);
  for (int k = 0; k < 3; ++k) sc[k] = required(*vertex, "scale_" + std::to_string(k), name);
  for (int k = 0; k < 4; ++k) rot[k] = required(*vertex, "rot_" + std::to_string(k), name);
  const int cop = required(*vertex, "opacity", name);
  int rest_count = 0;
  for (const auto& p : vertex->props)
    if (!p.is_list && p.name.rfind("f_rest_", 0) == 0) ++rest_count;
  uint32_t degree = 0;
  switch (rest_count) {
    case 0: degree = 0; break;
    case 9: degree = 1; break;
    case 24: degree = 2; break;
    case 45: degree = 3; break;
    default:
      throw scene::InputError(name, "header", std::to_string(rest_count) +
                                                  " f_rest properties (expected 0, 9, 24 or 45 for SH degree 0-3)");
  }
  std::vector<int> rest(static_cast<size_t>(rest_count));
  for (int k = 0; k < rest_count; ++k) rest[static_cast<size_t>(k)] = required(*vertex, "f_rest_" + std::to_string(k), name);

  const std::string_view body = bytes.substr(h.body_offset);
  for (const PlyElement& e : h.elements) {
    if (!world::ply_rows_fit(e, h.format, body.size()))
      throw scene::InputError(name, "header", e.name + " count " + std::to_string(e.count) + " exceeds the file");
    if (&e == vertex) break;
  }
  PlyCursor in(body, h.format, h.body_offset, h.header_lines + 1, PlyCursor::AsciiInts::Lenient);
  GaussianCloud cloud;
  cloud.sh_degree = degree;
  const uint32_t K = cloud.sh_coeffs();
  const size_t n = static_cast<size_t>(vertex->count);
  cloud.positions.reserve(n);
  cloud.scales.reserve(n);
  cloud.rotations.reserve(n);
  cloud.opacities.reserve(n);
  cloud.sh.reserve(n * K * 3);
  std::vector<float> coeffs(K * 3);
  for (const PlyElement& e : h.elements) {
    std::vector<double> v(e.props.size(), 0.0);
    for (uint64_t row = 0; row < e.count; ++row) {
      read_row(in, e, v, name, row);
      if (&e != vertex) continue;
      auto at = [&](int c) { return v[static_cast<size_t>(c)]; };
      auto check = [&](int c) {
        const double x = at(c);
        if (!std::isfinite(x))
          throw scene::InputError(name, vertex_where(row),
                                  "property '" + e.props[static_cast<size_t>(c)].name + "' is " +
                                      (std::isnan(x) ? "NaN" : "infinite"));
        return x;
      };
      const glm::dvec3 p(check(cx), check(cy), check(cz));
      glm::dvec3 s;
      for (int k = 0; k < 3; ++k) {
        s[k] = std::exp(check(sc[k]));
        if (!std::isfinite(float(s[k])) || !(float(s[k]) > 0.0f))
          throw scene::InputError(name, vertex_where(row),
                                  "scale_" + std::to_string(k) + " = " + std::to_string(at(sc[k])) +
                                      " overflows or underflows float after exp");
      }
      double q[4], qn = 0.0;
      for (int k = 0; k < 4; ++k) {
        q[k] = check(rot[k]);
        qn += q[k] * q[k];
      }
      qn = std::sqrt(qn);
      if (!(qn > 1e-30) || !std::isfinite(qn)) throw scene::InputError(name, vertex_where(row), "zero quaternion (rot_0..3)");
      const double op = sigmoid(check(cop));
      for (int c = 0; c < 3; ++c) coeffs[static_cast<size_t>(c)] = static_cast<float>(check(dc[c]));
      for (uint32_t c = 0; c < 3; ++c)
        for (uint32_t k = 1; k < K; ++k)
          coeffs[k * 3 + c] = static_cast<float>(check(rest[c * (K - 1) + (k - 1)]));
      for (float f : coeffs)
        if (!std::isfinite(f)) throw scene::InputError(name, vertex_where(row), "SH coefficient overflows float");
      cloud.add(p, glm::vec3(s), glm::vec4(q[0] / qn, q[1] / qn, q[2] / qn, q[3] / qn), static_cast<float>(op),
                coeffs.data());
    }
    if (&e == vertex) break;  // later elements and trailing bytes are ignored
  }
  return cloud;
}

GaussianCloud read_gaussians_ply(const std::string& path) { return gaussians_from_ply_bytes(scene::read_file(path), path); }

std::string gaussians_to_ply_bytes(const GaussianCloud& cloud) {
  cloud.validate();
  const uint32_t K = cloud.sh_coeffs();
  std::ostringstream h;
  h << "ply\nformat binary_little_endian 1.0\ncomment written by InfiniCube-VK\nelement vertex " << cloud.size()
    << "\n";
  for (const char* p : {"x", "y", "z", "nx", "ny", "nz", "f_dc_0", "f_dc_1", "f_dc_2"}) h << "property float " << p << "\n";
  for (uint32_t k = 0; k < 3 * (K - 1); ++k) h << "property float f_rest_" << k << "\n";
  h << "property float opacity\n";
  for (int k = 0; k < 3; ++k) h << "property float scale_" << k << "\n";
  for (int k = 0; k < 4; ++k) h << "property float rot_" << k << "\n";
  h << "end_header\n";
  std::string out = h.str();
  out.reserve(out.size() + cloud.size() * (14 + 3 * K) * 4);
  for (size_t i = 0; i < cloud.size(); ++i) {
    const auto& p = cloud.positions[i];
    for (double v : {p.x, p.y, p.z}) put_f32(out, static_cast<float>(v));
    for (int k = 0; k < 3; ++k) put_f32(out, 0.0f);
    const float* c = &cloud.sh[i * K * 3];
    for (int ch = 0; ch < 3; ++ch) put_f32(out, c[ch]);
    for (uint32_t ch = 0; ch < 3; ++ch)
      for (uint32_t k = 1; k < K; ++k) put_f32(out, c[k * 3 + ch]);
    const double o = std::clamp(static_cast<double>(cloud.opacities[i]), 1e-12, 1.0 - 1e-7);
    put_f32(out, static_cast<float>(std::log(o / (1.0 - o))));
    for (int k = 0; k < 3; ++k) put_f32(out, static_cast<float>(std::log(static_cast<double>(cloud.scales[i][k]))));
    const auto& q = cloud.rotations[i];
    for (int k = 0; k < 4; ++k) put_f32(out, q[k]);
  }
  return out;
}

void write_gaussians_ply(const std::string& path, const GaussianCloud& cloud) {
  scene::write_file_atomic(path, gaussians_to_ply_bytes(cloud));
}

CloudSummary summarize(const GaussianCloud& cloud) {
  CloudSummary s;
  s.count = cloud.size();
  s.sh_degree = cloud.sh_degree;
  if (cloud.size() == 0) return s;
  s.min = s.max = cloud.positions[0];
  double osum = 0.0;
  s.opacity_min = s.opacity_max = cloud.opacities[0];
  std::vector<float> sc;
  sc.reserve(cloud.size() * 3);
  for (size_t i = 0; i < cloud.size(); ++i) {
    s.min = glm::min(s.min, cloud.positions[i]);
    s.max = glm::max(s.max, cloud.positions[i]);
    s.centroid += cloud.positions[i];
    osum += static_cast<double>(cloud.opacities[i]);
    s.opacity_min = std::min<double>(s.opacity_min, cloud.opacities[i]);
    s.opacity_max = std::max<double>(s.opacity_max, cloud.opacities[i]);
    for (int k = 0; k < 3; ++k) sc.push_back(cloud.scales[i][k]);
  }
  s.centroid /= static_cast<double>(cloud.size());
  s.opacity_mean = osum / static_cast<double>(cloud.size());
  std::sort(sc.begin(), sc.end());
  s.scale_min = sc.front();
  s.scale_max = sc.back();
  s.scale_median = sc[sc.size() / 2];
  return s;
}

}  // namespace icube::splat

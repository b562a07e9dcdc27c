// Static + dynamic Gaussian scenes and their placement; see splat_scene.h.
#include "splat/splat_scene.h"

#include "scene/atomic_file.h"
#include "scene/frames.h"
#include "scene/input_error.h"
#include "splat/splat_format.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <numbers>
#include <set>
#include <stdexcept>

namespace icube::splat {

namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;

constexpr size_t kMaxFrames = 10'000'000;

// ---- SH basis of the renderer (rasterizer_cpu.cpp sh_color), one degree at a time ----

constexpr double kC1 = 0.4886025119029199;
constexpr double kC2[5] = {1.0925484305920792, -1.0925484305920792, 0.31539156525252005, -1.0925484305920792,
                           0.5462742152960396};
constexpr double kC3[7] = {-0.5900435899266435, 2.890611442640554, -0.4570457994644658, 0.3731763325901154,
                           -0.4570457994644658, 1.445305721320277, -0.5900435899266435};

void sh_basis(uint32_t l, const glm::dvec3& d, double* y) {
  const double x = d.x, yy_ = d.y, z = d.z;
  const double xx = x * x, yy = yy_ * yy_, zz = z * z;
  if (l == 1) {
    y[0] = -kC1 * yy_;
    y[1] = kC1 * z;
    y[2] = -kC1 * x;
  } else if (l == 2) {
    y[0] = kC2[0] * x * yy_;
    y[1] = kC2[1] * yy_ * z;
    y[2] = kC2[2] * (2.0 * zz - xx - yy);
    y[3] = kC2[3] * x * z;
    y[4] = kC2[4] * (xx - yy);
  } else {
    y[0] = kC3[0] * yy_ * (3.0 * xx - yy);
    y[1] = kC3[1] * x * yy_ * z;
    y[2] = kC3[2] * yy_ * (4.0 * zz - xx - yy);
    y[3] = kC3[3] * z * (2.0 * zz - 3.0 * xx - 3.0 * yy);
    y[4] = kC3[4] * x * (4.0 * zz - xx - yy);
    y[5] = kC3[5] * z * (xx - yy);
    y[6] = kC3[6] * x * (xx - 3.0 * yy);
  }
}

// Solves the n×n system a·x = b (row-major, partial pivoting) for m right-hand sides in place
// (b is n×m row-major).
void solve(std::vector<double>& a, std::vector<double>& b, int n, int m) {
  for (int c = 0; c < n; ++c) {
    int piv = c;
    for (int r = c + 1; r < n; ++r)
      if (std::fabs(a[r * n + c]) > std::fabs(a[piv * n + c])) piv = r;
    if (piv != c) {
      for (int k = 0; k < n; ++k) std::swap(a[c * n + k], a[piv * n + k]);
      for (int k = 0; k < m; ++k) std::swap(b[c * m + k], b[piv * m + k]);
    }
    const double inv = 1.0 / a[c * n + c];
    for (int r = 0; r < n; ++r) {
      if (r == c) continue;
      const double f = a[r * n + c] * inv;
      if (f == 0.0) continue;
      for (int k = c; k < n; ++k) a[r * n + k] -= f * a[c * n + k];
      for (int k = 0; k < m; ++k) b[r * m + k] -= f * b[c * m + k];
    }
  }
  for (int r = 0; r < n; ++r)
    for (int k = 0; k < m; ++k) b[r * m + k] /= a[r * n + r];
}

// Sample directions: a Fibonacci sphere (well spread, so the least-squares system is well conditioned).
std::vector<glm::dvec3> sample_directions(int count) {
  std::vector<glm::dvec3> d;
  const double golden = std::numbers::pi * (3.0 - std::sqrt(5.0));
  for (int i = 0; i < count; ++i) {
    const double z = 1.0 - (i + 0.5) * 2.0 / count;
    const double r = std::sqrt(1.0 - z * z);
    d.emplace_back(r * std::cos(golden * i), r * std::sin(golden * i), z);
  }
  return d;
}

void reserve_more(GaussianCloud& out, size_t n) {
  out.positions.reserve(out.size() + n);
  out.scales.reserve(out.size() + n);
  out.rotations.reserve(out.size() + n);
  out.opacities.reserve(out.size() + n);
  out.sh.reserve((out.size() + n) * out.sh_coeffs() * 3);
}

// ---- JSON helpers -----------------------------------------------------------------

struct Where {
  const std::string& file;
  std::string ptr;
  Where at(const std::string& key) const { return {file, ptr + "/" + key}; }
  Where at(size_t i) const { return {file, ptr + "/" + std::to_string(i)}; }
  [[noreturn]] void fail(const std::string& what) const { throw scene::InputError(file, ptr.empty() ? "/" : ptr, what); }
};

const char* type_name(const Json& j) { return j.type_name(); }

void allow_keys(const Json& obj, const Where& w, std::initializer_list<const char*> keys) {
  for (auto it = obj.begin(); it != obj.end(); ++it) {
    bool ok = false;
    for (const char* k : keys) ok = ok || it.key() == k;
    if (ok) continue;
    std::string list;
    for (const char* k : keys) list += (list.empty() ? "" : ", ") + std::string(k);
    w.at(it.key()).fail("unknown key (expected one of: " + list + ")");
  }
}

double number(const Json& j, const Where& w) {
  if (!j.is_number()) w.fail(std::string("expected a number, got ") + type_name(j));
  const double v = j.get<double>();
  if (!std::isfinite(v)) w.fail("number is not finite");
  return v;
}

std::string string_value(const Json& j, const Where& w) {
  if (!j.is_string()) w.fail(std::string("expected a string, got ") + type_name(j));
  return j.get<std::string>();
}

uint64_t index_value(const Json& j, const Where& w, uint64_t limit) {
  if (!j.is_number_integer()) w.fail(std::string("expected a non-negative integer, got ") + type_name(j));
  if (j.is_number_unsigned()) {
    const uint64_t v = j.get<uint64_t>();
    if (v >= limit) w.fail(std::to_string(v) + " is too large (limit " + std::to_string(limit - 1) + ")");
    return v;
  }
  const int64_t v = j.get<int64_t>();
  if (v < 0) w.fail(std::to_string(v) + " is negative");
  if (static_cast<uint64_t>(v) >= limit) w.fail(std::to_string(v) + " is too large (limit " + std::to_string(limit - 1) + ")");
  return static_cast<uint64_t>(v);
}

std::vector<double> number_array(const Json& j, const Where& w, size_t n) {
  if (!j.is_array() || j.size() != n) w.fail("expected an array of " + std::to_string(n) + " numbers");
  std::vector<double> v(n);
  for (size_t i = 0; i < n; ++i) v[i] = number(j[i], w.at(i));
  return v;
}

glm::dmat4 pose_from_entry(const Json& e, const Where& w) {
  glm::dmat4 m(1.0);
  if (e.contains("object_to_world")) {
    allow_keys(e, w, {"frame", "object_to_world"});
    const Where wm = w.at("object_to_world");
    const Json& a = e["object_to_world"];
    if (!a.is_array() || a.size() != 4) wm.fail("expected 4 rows of 4 numbers (row-major 4x4)");
    for (size_t r = 0; r < 4; ++r) {
      const auto row = number_array(a[r], wm.at(r), 4);
      for (size_t c = 0; c < 4; ++c) m[static_cast<int>(c)][static_cast<int>(r)] = row[c];  // glm: m[col][row]
    }
  } else if (e.contains("position")) {
    const auto p = number_array(e["position"], w.at("position"), 3);
    glm::dmat3 r(1.0);
    if (e.contains("quaternion")) {
      allow_keys(e, w, {"frame", "position", "quaternion"});
      const auto q = number_array(e["quaternion"], w.at("quaternion"), 4);
      const double n = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
      if (!(std::fabs(n - 1.0) <= 1e-3))
        w.at("quaternion").fail("quaternion (w, x, y, z) has norm " + std::to_string(n) + ", expected 1");
      const double qw = q[0] / n, x = q[1] / n, y = q[2] / n, z = q[3] / n;
      r = glm::dmat3(1 - 2 * (y * y + z * z), 2 * (x * y + qw * z), 2 * (x * z - qw * y),  // column 0
                     2 * (x * y - qw * z), 1 - 2 * (x * x + z * z), 2 * (y * z + qw * x),  // column 1
                     2 * (x * z + qw * y), 2 * (y * z - qw * x), 1 - 2 * (x * x + y * y));
    } else if (e.contains("yaw")) {
      allow_keys(e, w, {"frame", "position", "yaw", "pitch", "roll"});
      scene::BoxState b;
      b.heading = number(e["yaw"], w.at("yaw"));
      if (e.contains("pitch")) b.pitch = number(e["pitch"], w.at("pitch"));
      if (e.contains("roll")) b.roll = number(e["roll"], w.at("roll"));
      r = scene::box_rotation(b);
    } else {
      w.fail("a pose with 'position' also needs 'yaw' (+ optional 'pitch', 'roll') or 'quaternion' [w, x, y, z]");
    }
    m = glm::dmat4(r);
    m[3] = glm::dvec4(p[0], p[1], p[2], 1.0);
  } else {
    w.fail("a track entry needs 'object_to_world' (4x4) or 'position' with 'yaw' or 'quaternion'");
  }
  const std::string err = rigid_transform_error(m);
  if (!err.empty()) w.fail("pose is not rigid: " + err);
  return m;
}

}  // namespace

// ---- placement --------------------------------------------------------------------

std::string rigid_transform_error(const glm::dmat4& m) {
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r)
      if (!std::isfinite(m[c][r])) return "non-finite entry";
  if (m[0][3] != 0.0 || m[1][3] != 0.0 || m[2][3] != 0.0 || m[3][3] != 1.0) return "bottom row is not (0, 0, 0, 1)";
  const glm::dmat3 r(m);
  const glm::dmat3 rtr = glm::transpose(r) * r;
  double worst = 0.0;
  for (int c = 0; c < 3; ++c)
    for (int k = 0; k < 3; ++k) worst = std::max(worst, std::fabs(rtr[c][k] - (c == k ? 1.0 : 0.0)));
  if (!(worst <= 1e-6)) return "rotation is not orthonormal (|R^T R - I| = " + std::to_string(worst) + ")";
  if (!(glm::determinant(r) > 0.0)) return "rotation has determinant -1 (a reflection)";
  return "";
}

glm::dvec4 quaternion_from_rotation(const glm::dmat3& m) {
  // m[col][row]; R(i, j) = m[j][i].
  auto R = [&](int i, int j) { return m[j][i]; };
  const double tr = R(0, 0) + R(1, 1) + R(2, 2);
  glm::dvec4 q;
  if (tr > 0.0) {
    const double s = std::sqrt(tr + 1.0) * 2.0;
    q = {0.25 * s, (R(2, 1) - R(1, 2)) / s, (R(0, 2) - R(2, 0)) / s, (R(1, 0) - R(0, 1)) / s};
  } else if (R(0, 0) > R(1, 1) && R(0, 0) > R(2, 2)) {
    const double s = std::sqrt(1.0 + R(0, 0) - R(1, 1) - R(2, 2)) * 2.0;
    q = {(R(2, 1) - R(1, 2)) / s, 0.25 * s, (R(0, 1) + R(1, 0)) / s, (R(0, 2) + R(2, 0)) / s};
  } else if (R(1, 1) > R(2, 2)) {
    const double s = std::sqrt(1.0 + R(1, 1) - R(0, 0) - R(2, 2)) * 2.0;
    q = {(R(0, 2) - R(2, 0)) / s, (R(0, 1) + R(1, 0)) / s, 0.25 * s, (R(1, 2) + R(2, 1)) / s};
  } else {
    const double s = std::sqrt(1.0 + R(2, 2) - R(0, 0) - R(1, 1)) * 2.0;
    q = {(R(1, 0) - R(0, 1)) / s, (R(0, 2) + R(2, 0)) / s, (R(1, 2) + R(2, 1)) / s, 0.25 * s};
  }
  return q / glm::length(q);
}

glm::dvec4 quaternion_multiply(const glm::dvec4& a, const glm::dvec4& b) {
  // (w, x, y, z) stored in x..w of dvec4.
  const double aw = a[0], ax = a[1], ay = a[2], az = a[3];
  const double bw = b[0], bx = b[1], by = b[2], bz = b[3];
  return {aw * bw - ax * bx - ay * by - az * bz, aw * bx + ax * bw + ay * bz - az * by,
          aw * by - ax * bz + ay * bw + az * bx, aw * bz + ax * by - ay * bx + az * bw};
}

ShRotation::ShRotation(const glm::dmat3& r, uint32_t max_degree) {
  // Colour'(d') = colour(Rᵀd'): with A[j][k] = Y_k(d_j) and B[j][k] = Y_k(Rᵀ d_j) over sample
  // directions d_j, A·c' = B·c, so c' = (AᵀA)⁻¹AᵀB·c (exact: each degree's span is rotation invariant).
  const auto dirs = sample_directions(32);
  const glm::dmat3 rt = glm::transpose(r);
  for (uint32_t l = 1; l <= std::min(max_degree, 3u); ++l) {
    const int n = static_cast<int>(2 * l + 1);
    std::vector<double> ata(n * n, 0.0), atb(n * n, 0.0);
    double ya[7], yb[7];
    for (const auto& d : dirs) {
      sh_basis(l, d, ya);
      sh_basis(l, rt * d, yb);
      for (int i = 0; i < n; ++i)
        for (int k = 0; k < n; ++k) {
          ata[i * n + k] += ya[i] * ya[k];
          atb[i * n + k] += ya[i] * yb[k];
        }
    }
    solve(ata, atb, n, n);
    block[l - 1] = std::move(atb);
  }
}

void ShRotation::apply(float* coeffs, uint32_t degree) const {
  double in[7], out[7];
  for (uint32_t l = 1; l <= degree; ++l) {
    const auto& m = block[l - 1];
    if (m.empty()) throw std::logic_error("ShRotation: degree above the one it was built for");
    const uint32_t n = 2 * l + 1, first = l * l;
    for (uint32_t c = 0; c < 3; ++c) {
      for (uint32_t k = 0; k < n; ++k) in[k] = coeffs[(first + k) * 3 + c];
      for (uint32_t i = 0; i < n; ++i) {
        double s = 0.0;
        for (uint32_t k = 0; k < n; ++k) s += m[i * n + k] * in[k];
        out[i] = s;
      }
      for (uint32_t k = 0; k < n; ++k) coeffs[(first + k) * 3 + c] = static_cast<float>(out[k]);
    }
  }
}

void append_cloud(GaussianCloud& out, const GaussianCloud& part) {
  if (part.sh_degree > out.sh_degree) throw std::invalid_argument("append_cloud: part has a higher SH degree");
  reserve_more(out, part.size());
  const uint32_t kp = part.sh_coeffs(), ko = out.sh_coeffs();
  std::vector<float> c(ko * 3, 0.0f);
  for (size_t i = 0; i < part.size(); ++i) {
    std::copy_n(&part.sh[i * kp * 3], kp * 3, c.begin());
    out.add(part.positions[i], part.scales[i], part.rotations[i], part.opacities[i], c.data());
  }
}

void append_placed(GaussianCloud& out, const GaussianCloud& part, const glm::dmat4& T) {
  if (part.sh_degree > out.sh_degree) throw std::invalid_argument("append_placed: part has a higher SH degree");
  const std::string err = rigid_transform_error(T);
  if (!err.empty()) throw std::invalid_argument("append_placed: pose is not rigid: " + err);
  const glm::dmat3 r(T);
  const glm::dvec3 t(T[3]);
  const glm::dvec4 qr = quaternion_from_rotation(r);
  const ShRotation shr(r, part.sh_degree);
  reserve_more(out, part.size());
  const uint32_t kp = part.sh_coeffs(), ko = out.sh_coeffs();
  std::vector<float> c(ko * 3, 0.0f);
  for (size_t i = 0; i < part.size(); ++i) {
    std::copy_n(&part.sh[i * kp * 3], kp * 3, c.begin());
    shr.apply(c.data(), part.sh_degree);
    const glm::dvec4 q = glm::normalize(quaternion_multiply(qr, glm::dvec4(part.rotations[i])));
    out.add(r * part.positions[i] + t, part.scales[i], glm::vec4(q), part.opacities[i], c.data());
  }
}

uint32_t max_sh_degree(const SplatScene& scene) {
  uint32_t degree = scene.static_set.sh_degree;
  for (const auto& o : scene.objects) degree = std::max(degree, o.gaussians.sh_degree);
  return degree;
}

GaussianCloud compose_objects(const std::vector<SplatObject>& objects, size_t frame, uint32_t sh_degree) {
  GaussianCloud out;
  out.sh_degree = sh_degree;
  for (const auto& o : objects)
    if (const glm::dmat4* T = o.pose(frame)) append_placed(out, o.gaussians, *T);
  return out;
}

GaussianCloud compose_frame(const SplatScene& scene, size_t frame) {
  uint32_t degree = scene.static_set.sh_degree;
  size_t total = scene.static_set.size();
  for (const auto& o : scene.objects)
    if (o.pose(frame)) {
      degree = std::max(degree, o.gaussians.sh_degree);
      total += o.gaussians.size();
    }
  GaussianCloud out;
  out.sh_degree = degree;
  reserve_more(out, total);
  if (degree == scene.static_set.sh_degree) {
    out = scene.static_set;
    reserve_more(out, total - out.size());
  } else {
    append_cloud(out, scene.static_set);
  }
  for (const auto& o : scene.objects)
    if (const glm::dmat4* T = o.pose(frame)) append_placed(out, o.gaussians, *T);
  return out;
}

// ---- reading ------------------------------------------------------------------------

SplatScene splat_scene_from_json(std::string_view text, const std::string& name, const std::string& base_dir) {
  Json doc;
  try {
    doc = Json::parse(text.begin(), text.end());
  } catch (const Json::exception& e) {  // parse_error, and out_of_range for numbers like 1e999
    std::string m = e.what();
    if (m.rfind("[json.exception.", 0) == 0 && m.find("] ") != std::string::npos) m.erase(0, m.find("] ") + 2);
    throw scene::InputError(name, "", "not valid JSON: " + m);
  }
  const Where root{name, ""};
  if (!doc.is_object()) root.fail("expected a JSON object");
  if (!doc.contains("format") || !doc["format"].is_string() || doc["format"].get<std::string>() != kSplatSceneFormat)
    root.at("format").fail(std::string("expected \"") + kSplatSceneFormat + "\"");
  if (!doc.contains("version")) root.at("version").fail("missing");
  if (!doc["version"].is_number_integer() || doc["version"].get<int64_t>() != kSplatSceneVersion)
    root.at("version").fail("unsupported version " + doc["version"].dump() + " (this build reads " +
                            std::to_string(kSplatSceneVersion) + ")");
  allow_keys(doc, root, {"format", "version", "static", "frames", "objects"});

  std::map<std::string, GaussianCloud> cache;
  auto load = [&](const Json& j, const Where& w) -> std::pair<std::string, const GaussianCloud*> {
    const std::string rel = string_value(j, w);
    if (rel.empty()) w.fail("empty path");
    const fs::path p = fs::path(rel).is_absolute() ? fs::path(rel) : fs::path(base_dir) / rel;
    const std::string path = p.lexically_normal().string();
    auto it = cache.find(path);
    if (it == cache.end()) {
      std::error_code ec;
      if (!fs::is_regular_file(p, ec)) w.fail("Gaussian file '" + path + "' not found");
      it = cache.emplace(path, read_gaussians(path)).first;  // errors name that file and its Gaussian
    }
    return {path, &it->second};
  };

  SplatScene s;
  s.source = name;
  if (doc.contains("static") && !doc["static"].is_null()) s.static_set = *load(doc["static"], root.at("static")).second;

  bool frames_given = false;
  if (doc.contains("frames")) {
    s.frame_count = index_value(doc["frames"], root.at("frames"), kMaxFrames + 1);
    frames_given = true;
  }
  if (doc.contains("objects")) {
    const Json& objs = doc["objects"];
    const Where wo = root.at("objects");
    if (!objs.is_array()) wo.fail(std::string("expected an array, got ") + type_name(objs));
    std::set<int64_t> ids;
    for (size_t i = 0; i < objs.size(); ++i) {
      const Json& o = objs[i];
      const Where w = wo.at(i);
      if (!o.is_object()) w.fail(std::string("expected an object, got ") + type_name(o));
      allow_keys(o, w, {"id", "gaussians", "track"});
      SplatObject obj;
      if (!o.contains("id") || !o["id"].is_number_integer()) w.at("id").fail("expected an integer id");
      obj.id = o["id"].get<int64_t>();
      if (!ids.insert(obj.id).second) w.at("id").fail("duplicate object id " + std::to_string(obj.id));
      if (!o.contains("gaussians")) w.at("gaussians").fail("missing");
      const auto [path, cloud] = load(o["gaussians"], w.at("gaussians"));
      obj.source = path;
      obj.gaussians = *cloud;
      if (!o.contains("track")) w.at("track").fail("missing");
      const Json& tr = o["track"];
      const Where wt = w.at("track");
      if (!tr.is_array()) wt.fail(std::string("expected an array, got ") + type_name(tr));
      for (size_t k = 0; k < tr.size(); ++k) {
        const Json& e = tr[k];
        const Where we = wt.at(k);
        if (!e.is_object()) we.fail(std::string("expected an object, got ") + type_name(e));
        if (!e.contains("frame")) we.at("frame").fail("missing");
        const size_t f = index_value(e["frame"], we.at("frame"), kMaxFrames);
        if (frames_given && f >= s.frame_count)
          we.at("frame").fail("frame " + std::to_string(f) + " is outside the scene's " + std::to_string(s.frame_count) +
                              " frames (\"frames\")");
        const glm::dmat4 m = pose_from_entry(e, we);
        if (f >= obj.poses.size()) {
          obj.poses.resize(f + 1, glm::dmat4(1.0));
          obj.present.resize(f + 1, 0);
        }
        if (obj.present[f]) we.at("frame").fail("frame " + std::to_string(f) + " listed twice");
        obj.poses[f] = m;
        obj.present[f] = 1;
      }
      if (!frames_given) s.frame_count = std::max(s.frame_count, obj.poses.size());
      s.objects.push_back(std::move(obj));
    }
  }
  for (auto& o : s.objects) {
    o.poses.resize(s.frame_count, glm::dmat4(1.0));
    o.present.resize(s.frame_count, 0);
  }
  return s;
}

SplatScene read_splat_scene(const std::string& path) {
  const std::string bytes = scene::read_file(path);
  const size_t first = bytes.find_first_not_of(" \t\r\n");
  const bool looks_json = first != std::string::npos && bytes[first] == '{' && !is_ply_bytes(bytes) &&
                          !has_splat_extension(path);
  if (looks_json) {
    const fs::path parent = fs::path(path).parent_path();
    return splat_scene_from_json(bytes, path, parent.empty() ? "." : parent.string());
  }
  SplatScene s;
  s.source = path;
  s.static_set = gaussians_from_bytes(bytes, path);
  return s;
}

}  // namespace icube::splat

// The GSM's outputs in the package's conventions; see gsm_gaussians.h.
#include "lift/gsm_gaussians.h"

#include <glm/gtc/quaternion.hpp>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace icube::lift {

size_t GsmGaussianTensors::count() const { return means && !means->shape.empty() ? size_t(means->dim(0)) : 0; }

namespace {

void check_tensors(const GsmGaussianTensors& g) {
  if (!g.means || !g.scales || !g.rotations || !g.opacities || !g.colors)
    throw std::invalid_argument("gsm gaussians: a tensor is missing");
  const int64_t n = int64_t(g.count());
  auto shaped = [&](const nn::CpuTensor& t, int64_t cols) {
    return t.rank() == 2 && t.dim(0) == n && (cols < 0 ? t.dim(1) >= 3 : t.dim(1) == cols);
  };
  if (n > 0 && !(shaped(*g.means, 3) && shaped(*g.scales, 3) && shaped(*g.rotations, 4) && shaped(*g.opacities, 1) &&
                 shaped(*g.colors, -1)))
    throw std::invalid_argument("gsm gaussians: tensors of " + std::to_string(n) + " Gaussians have shapes " +
                                g.means->shape_text() + ", " + g.scales->shape_text() + ", " + g.rotations->shape_text() +
                                ", " + g.opacities->shape_text() + ", " + g.colors->shape_text());
}

bool rotation_is_identity(const glm::dmat4& m) {
  for (int c = 0; c < 3; ++c)
    for (int r = 0; r < 3; ++r)
      if (m[c][r] != (c == r ? 1.0 : 0.0)) return false;
  return true;
}

}  // namespace

void append_gsm_gaussians(splat::GaussianCloud& out, const GsmGaussianTensors& g, const glm::dmat4& grid_to_target,
                          const std::vector<size_t>* rows, GsmConversionStats* stats) {
  check_tensors(g);
  if (out.sh_degree != 0) throw std::invalid_argument("gsm gaussians: the cloud must hold SH degree 0");
  const size_t n = rows ? rows->size() : g.count();
  const size_t color_cols = size_t(g.colors->dim(1));
  const bool same_axes = rotation_is_identity(grid_to_target);
  const glm::dquat turn = glm::quat_cast(glm::dmat3(grid_to_target));
  for (size_t k = 0; k < n; ++k) {
    const size_t i = rows ? (*rows)[k] : k;
    if (i >= g.count()) throw std::invalid_argument("gsm gaussians: row " + std::to_string(i) + " of " + std::to_string(g.count()));
    const float* m = &g.means->data[3 * i];
    const glm::dvec3 p = glm::dvec3(grid_to_target * glm::dvec4(double(m[0]), double(m[1]), double(m[2]), 1.0));
    glm::vec3 s;
    for (int a = 0; a < 3; ++a) {
      s[a] = g.scales->data[3 * i + size_t(a)];
      if (!(s[a] >= kMinGsmScale)) {
        s[a] = kMinGsmScale;
        if (stats) ++stats->floored_scales;
      }
    }
    const float* r = &g.rotations->data[4 * i];
    glm::vec4 q(r[0], r[1], r[2], r[3]);
    const glm::dvec4 qd(q);
    const double norm = std::sqrt(glm::dot(qd, qd));
    if (!(std::fabs(norm - 1.0) < 1e-3)) {
      q = glm::vec4(1.0f, 0.0f, 0.0f, 0.0f);
      if (stats) ++stats->identity_rotations;
    }
    if (!same_axes) {
      const glm::dquat qt = turn * glm::dquat(double(q.x), double(q.y), double(q.z), double(q.w));
      const glm::dquat u = glm::normalize(qt);
      q = glm::vec4(float(u.w), float(u.x), float(u.y), float(u.z));
    }
    const float* c = &g.colors->data[color_cols * i];
    float dc[3];
    for (int ch = 0; ch < 3; ++ch) dc[ch] = float((double(c[ch]) - 0.5) / splat::kShC0);
    out.add(p, s, q, g.opacities->data[i], dc);
  }
}

void GsmObjectPicker::add_frame(size_t frame, const GsmGaussianTensors& g, const std::vector<size_t>& rows,
                                const std::vector<GsmObjectBox>& boxes) {
  check_tensors(g);
  for (const GsmObjectBox& box : boxes) {
    const glm::dmat4 to_object = glm::inverse(box.object_to_grid);
    const glm::dvec3 half = box.lwh * 0.5;
    std::vector<size_t> inside;
    for (size_t i : rows) {
      const float* m = &g.means->data[3 * i];
      // The official test in float32 after a float32 inverse; here in double (a mean on the box's face
      // may fall either way).
      const glm::dvec3 x = glm::dvec3(to_object * glm::dvec4(double(m[0]), double(m[1]), double(m[2]), 1.0));
      if (std::fabs(x.x) <= half.x && std::fabs(x.y) <= half.y && std::fabs(x.z) <= half.z) inside.push_back(i);
    }
    auto it = picks_.find(box.id);
    if (it != picks_.end() && inside.size() <= it->second.rows.size()) continue;
    Pick& p = picks_[box.id];
    p.frame = frame;
    p.gaussians = g;
    p.rows = std::move(inside);
    p.grid_to_object = to_object;
  }
}

splat::SkyImage gsm_sky_image(const nn::CpuTensor& panorama) {
  const size_t r = panorama.rank();
  if ((r != 3 && r != 4) || (r == 4 && panorama.dim(0) != 1) || panorama.dim(r - 1) < 3)
    throw std::invalid_argument("gsm sky: the panorama is " + panorama.shape_text() + ", not [1, rows, cols, 3]");
  const size_t rows = size_t(panorama.dim(r - 3)), cols = size_t(panorama.dim(r - 2)), C = size_t(panorama.dim(r - 1));
  splat::SkyImage img;
  img.width = uint32_t(cols);
  img.height = uint32_t(rows);
  img.rgba.resize(rows * cols * 4);
  for (size_t p = 0; p < rows * cols; ++p) {
    for (size_t c = 0; c < 3; ++c) {
      const float v = panorama.data[p * C + c];
      img.rgba[4 * p + c] = uint8_t(std::lround(std::clamp(std::isfinite(v) ? double(v) : 0.0, 0.0, 1.0) * 255.0));
    }
    img.rgba[4 * p + 3] = 255;
  }
  return img;
}

}  // namespace icube::lift

// CPU reference of the Gaussian splatting rasterizer; see rasterizer_cpu.h.
// The float arithmetic follows shaders/splat/project.glsl operation by
// operation; the per-pixel α is the reference's o·exp(power), which
// shaders/splat/blend.comp evaluates as 2^q with the conic folded with log2 e
// and log2 o (rounding-level differences; see that kernel's top comment).
#include "splat/rasterizer_cpu.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numeric>
#include <stdexcept>

namespace icube::splat {

namespace {
constexpr float kC0 = 0.28209479177387814f;
constexpr float kC1 = 0.4886025119029199f;
constexpr float kC2[5] = {1.0925484305920792f, -1.0925484305920792f, 0.31539156525252005f, -1.0925484305920792f,
                          0.5462742152960396f};
constexpr float kC3[7] = {-0.5900435899266435f, 2.890611442640554f, -0.4570457994644658f, 0.3731763325901154f,
                          -0.4570457994644658f, 1.445305721320277f, -0.5900435899266435f};

shader::SplatProjected culled() { return shader::SplatProjected{}; }

bool finite(float v) { return std::isfinite(v); }
}  // namespace

TileRect tile_rect(float mx, float my, float radius, uint32_t gx, uint32_t gy) {
  auto cl = [](float v, uint32_t g) { return static_cast<uint32_t>(std::clamp(v, 0.0f, static_cast<float>(g))); };
  TileRect r;
  r.x0 = cl((mx - radius) / 16.0f, gx);
  r.y0 = cl((my - radius) / 16.0f, gy);
  r.x1 = cl((mx + radius + 15.0f) / 16.0f, gx);
  r.y1 = cl((my + radius + 15.0f) / 16.0f, gy);
  if (r.x1 < r.x0) r.x1 = r.x0;
  if (r.y1 < r.y0) r.y1 = r.y0;
  return r;
}

float splat_log_cut(float opacity) { return std::log(0.9f / (255.0f * opacity)); }

void tile_row_span(const shader::SplatProjected& g, float log_cut, const TileRect& r, uint32_t ty, uint32_t& x0,
                   uint32_t& x1) {
  const float a = g.conic_x, b = g.conic_y, c = g.conic_z, mx = g.mean_x, my = g.mean_y;
  const float M = static_cast<float>(SPLAT_CULL_MARGIN);
  const float R = -2.0f * log_cut;
  const float D = a * c - b * b;
  const float ex = std::sqrt(R * c / D);
  const float ey = std::sqrt(R * a / D);
  const float lo = std::max(static_cast<float>(ty * 16u) - M - my, -ey);
  const float hi = std::min(static_cast<float>(ty * 16u + 16u) + M - my, ey);
  const float dyr = -(b / c) * ex;
  const float yr = std::min(std::max(dyr, lo), hi);
  const float yl = std::min(std::max(-dyr, lo), hi);
  const float sr = std::sqrt(std::max(0.0f, a * R - D * (yr * yr)));
  const float sl = std::sqrt(std::max(0.0f, a * R - D * (yl * yl)));
  const float xr = mx + (sr - b * yr) / a;
  const float xl = mx + (-sl - b * yl) / a;
  const float fx0 = std::floor((xl - M) / 16.0f);
  const float fx1 = std::floor((xr + M) / 16.0f) + 1.0f;
  const float all = R + D + ex + ey + xr + xl;
  if (!std::isfinite(all) || !(D > 0.0f) || !(a > 0.0f) || !(c > 0.0f)) {
    x0 = r.x0;
    x1 = r.x1;
    return;
  }
  if (lo > hi) {
    x0 = x1 = r.x0;
    return;
  }
  const float f0 = std::min(std::max(fx0, static_cast<float>(r.x0)), static_cast<float>(r.x1));
  const float f1 = std::min(std::max(fx1, f0), static_cast<float>(r.x1));
  x0 = static_cast<uint32_t>(f0);
  x1 = static_cast<uint32_t>(f1);
}

uint32_t tile_count(const shader::SplatProjected& g, uint32_t gx, uint32_t gy, TileRule rule) {
  if (g.radius <= 0.0f) return 0;
  const TileRect r = tile_rect(g.mean_x, g.mean_y, g.radius, gx, gy);
  if (rule == TileRule::Rect) return r.area();
  const float cut = splat_log_cut(g.opacity);
  uint32_t n = 0;
  for (uint32_t y = r.y0; y < r.y1; ++y) {
    uint32_t x0, x1;
    tile_row_span(g, cut, r, y, x0, x1);
    n += x1 - x0;
  }
  return n;
}

glm::vec3 sh_color(const float* sh, uint32_t degree, const glm::vec3& dir) {
  auto s = [&](int k) { return glm::vec3(sh[3 * k], sh[3 * k + 1], sh[3 * k + 2]); };
  glm::vec3 c = kC0 * s(0);
  if (degree > 0) {
    const float x = dir.x, y = dir.y, z = dir.z;
    c = c - kC1 * y * s(1) + kC1 * z * s(2) - kC1 * x * s(3);
    if (degree > 1) {
      const float xx = x * x, yy = y * y, zz = z * z, xy = x * y, yz = y * z, xz = x * z;
      c = c + kC2[0] * xy * s(4) + kC2[1] * yz * s(5) + kC2[2] * (2.0f * zz - xx - yy) * s(6) + kC2[3] * xz * s(7) +
          kC2[4] * (xx - yy) * s(8);
      if (degree > 2) {
        c = c + kC3[0] * y * (3.0f * xx - yy) * s(9) + kC3[1] * xy * z * s(10) +
            kC3[2] * y * (4.0f * zz - xx - yy) * s(11) + kC3[3] * z * (2.0f * zz - 3.0f * xx - 3.0f * yy) * s(12) +
            kC3[4] * x * (4.0f * zz - xx - yy) * s(13) + kC3[5] * z * (xx - yy) * s(14) +
            kC3[6] * x * (xx - 3.0f * yy) * s(15);
      }
    }
  }
  return glm::max(c + 0.5f, glm::vec3(0.0f));
}

shader::SplatProjected project_gaussian(const glm::vec3& d, float opacity, const float cov[6], const float* sh,
                                        uint32_t sh_degree, const shader::SplatPreprocessParams& f) {
  const glm::vec3 r0(f.r00, f.r01, f.r02), r1(f.r10, f.r11, f.r12), r2(f.r20, f.r21, f.r22);
  const float tx = r0.x * d.x + r0.y * d.y + r0.z * d.z;
  const float ty = r1.x * d.x + r1.y * d.y + r1.z * d.z;
  const float tz = r2.x * d.x + r2.y * d.y + r2.z * d.z;
  if (!(tz > f.near_z) || !(tz <= f.far_z)) return culled();
  const float inv_z = 1.0f / tz;
  const float cxz = std::clamp(tx * inv_z, -f.lim_x_neg, f.lim_x_pos) * tz;
  const float cyz = std::clamp(ty * inv_z, -f.lim_y_neg, f.lim_y_pos) * tz;
  const float j00 = f.fx * inv_z, j02 = -f.fx * cxz * (inv_z * inv_z);
  const float j11 = f.fy * inv_z, j12 = -f.fy * cyz * (inv_z * inv_z);
  const glm::vec3 m0 = j00 * r0 + j02 * r2;
  const glm::vec3 m1 = j11 * r1 + j12 * r2;
  // Σ·m
  const glm::vec3 s0(cov[0] * m0.x + cov[1] * m0.y + cov[2] * m0.z, cov[1] * m0.x + cov[3] * m0.y + cov[4] * m0.z,
                     cov[2] * m0.x + cov[4] * m0.y + cov[5] * m0.z);
  const glm::vec3 s1(cov[0] * m1.x + cov[1] * m1.y + cov[2] * m1.z, cov[1] * m1.x + cov[3] * m1.y + cov[4] * m1.z,
                     cov[2] * m1.x + cov[4] * m1.y + cov[5] * m1.z);
  const float a0 = m0.x * s0.x + m0.y * s0.y + m0.z * s0.z;
  const float b = m0.x * s1.x + m0.y * s1.y + m0.z * s1.z;
  const float c0 = m1.x * s1.x + m1.y * s1.y + m1.z * s1.z;
  const float a = a0 + f.eps2d, c = c0 + f.eps2d;
  const float det = a * c - b * b;
  if (!(det > 0.0f) || !finite(det)) return culled();
  float op = opacity;
  if (f.antialiased != 0u) op = op * std::sqrt(std::max(2.5e-5f, (a0 * c0 - b * b) / det));
  if (!(op >= 1.0f / 255.0f)) return culled();
  const float det_inv = 1.0f / det;
  const float mid = 0.5f * (a + c);
  const float l1 = mid + std::sqrt(std::max(0.1f, mid * mid - det));
  const float l2 = mid - std::sqrt(std::max(0.1f, mid * mid - det));
  const float radius = std::ceil(3.0f * std::sqrt(std::max(l1, l2)));
  const float mx = f.fx * tx * inv_z + f.cx;
  const float my = f.fy * ty * inv_z + f.cy;
  if (!finite(mx) || !finite(my) || !finite(radius) || !finite(det_inv)) return culled();
  const TileRect rect = tile_rect(mx, my, radius, f.grid_x, f.grid_y);
  if (rect.area() == 0) return culled();
  shader::SplatProjected g{};
  g.mean_x = mx;
  g.mean_y = my;
  g.depth = tz;
  g.opacity = op;
  g.conic_x = c * det_inv;
  g.conic_y = -b * det_inv;
  g.conic_z = a * det_inv;
  g.radius = radius;
  const float len = std::sqrt(d.x * d.x + d.y * d.y + d.z * d.z);
  const glm::vec3 dir = len > 0.0f ? d / len : glm::vec3(0.0f, 0.0f, 1.0f);
  const glm::vec3 col = sh_color(sh, sh_degree, dir);
  g.r = col.x;
  g.g = col.y;
  g.b = col.z;
  return g;
}

std::vector<shader::SplatProjected> preprocess_cpu(const GaussianCloud& cloud, const render::Camera& cam,
                                                   const SplatOptions& opts) {
  const SplatFrame f = make_frame(cam, opts, glm::dvec3(0.0));
  const uint32_t K = cloud.sh_coeffs();
  std::vector<shader::SplatProjected> out(cloud.size());
  for (size_t i = 0; i < cloud.size(); ++i) {
    const glm::vec3 d(cloud.positions[i] - f.camera);  // camera-relative, in double, then float
    const auto cov = covariance3d(cloud.scales[i], cloud.rotations[i]);
    out[i] = project_gaussian(d, cloud.opacities[i], cov.data(), &cloud.sh[i * K * 3], cloud.sh_degree, f.pre);
  }
  return out;
}

TileBins bin_cpu(const std::vector<shader::SplatProjected>& proj, uint32_t gx, uint32_t gy, TileRule rule,
                 uint32_t depth_key_bits) {
  TileBins b;
  for (size_t i = 0; i < proj.size(); ++i) {
    const auto& g = proj[i];
    if (g.radius <= 0.0f) continue;
    const TileRect r = tile_rect(g.mean_x, g.mean_y, g.radius, gx, gy);
    const float cut = splat_log_cut(g.opacity);
    const uint32_t zbits = depth_sort_key(g.depth, depth_key_bits);
    for (uint32_t y = r.y0; y < r.y1; ++y) {
      uint32_t x0 = r.x0, x1 = r.x1;
      if (rule == TileRule::Ellipse) tile_row_span(g, cut, r, y, x0, x1);
      for (uint32_t x = x0; x < x1; ++x) {
        b.keys.push_back((uint64_t{y * gx + x} << 32) | zbits);
        b.values.push_back(static_cast<uint32_t>(i));
      }
    }
  }
  std::vector<uint32_t> order(b.keys.size());
  std::iota(order.begin(), order.end(), 0u);
  std::stable_sort(order.begin(), order.end(), [&](uint32_t l, uint32_t r) { return b.keys[l] < b.keys[r]; });
  std::vector<uint64_t> k(order.size());
  std::vector<uint32_t> v(order.size());
  for (size_t i = 0; i < order.size(); ++i) {
    k[i] = b.keys[order[i]];
    v[i] = b.values[order[i]];
  }
  b.keys = std::move(k);
  b.values = std::move(v);
  b.ranges.assign(size_t{gx} * gy * 2, 0u);
  for (size_t i = 0; i < b.keys.size(); ++i) {
    const uint32_t t = static_cast<uint32_t>(b.keys[i] >> 32);
    if (i == 0 || static_cast<uint32_t>(b.keys[i - 1] >> 32) != t) b.ranges[2 * t] = static_cast<uint32_t>(i);
    if (i + 1 == b.keys.size() || static_cast<uint32_t>(b.keys[i + 1] >> 32) != t)
      b.ranges[2 * t + 1] = static_cast<uint32_t>(i + 1);
  }
  return b;
}

SplatImage blend_cpu(const std::vector<shader::SplatProjected>& proj, const TileBins& bins, const render::Camera& cam,
                     const SplatOptions& opts) {
  SplatImage img;
  img.width = cam.K.width;
  img.height = cam.K.height;
  const uint32_t gx = (img.width + SPLAT_TILE - 1) / SPLAT_TILE;
  img.rgba.assign(size_t{img.width} * img.height * 4, 0.0f);
  img.depth.assign(size_t{img.width} * img.height * 2, 0.0f);
  const float o = static_cast<float>(render::pixel_offset(opts.pixels));
  validate_sky(opts.sky);
  float m[9];
  sky_ray_matrix(cam, m);
  for (uint32_t v = 0; v < img.height; ++v)
    for (uint32_t u = 0; u < img.width; ++u) {
      const uint32_t tile = (v / SPLAT_TILE) * gx + u / SPLAT_TILE;
      const float px = static_cast<float>(u) + o, py = static_cast<float>(v) + o;
      float T = 1.0f, cr = 0.0f, cg = 0.0f, cb = 0.0f, wz = 0.0f, median = 0.0f;
      for (uint32_t k = bins.ranges[2 * tile]; k < bins.ranges[2 * tile + 1]; ++k) {
        const auto& g = proj[bins.values[k]];
        const float dx = g.mean_x - px, dy = g.mean_y - py;
        const float power = -0.5f * (g.conic_x * dx * dx + g.conic_z * dy * dy) - g.conic_y * dx * dy;
        if (power > 0.0f) continue;
        const float alpha = std::min(0.99f, g.opacity * std::exp(power));
        if (alpha < 1.0f / 255.0f) continue;
        const float test_t = T * (1.0f - alpha);
        if (test_t < 1e-4f) break;
        const float w = alpha * T;
        cr += g.r * w;
        cg += g.g * w;
        cb += g.b * w;
        wz += g.depth * w;
        if (T > 0.5f && test_t <= 0.5f) median = g.depth;
        T = test_t;
      }
      const size_t p = size_t{v} * img.width + u;
      const glm::vec3 sky = opts.sky.kind == SkyKind::Background
                                ? opts.background
                                : sky_color(opts.sky, opts.background, sky_ray_dir(m, px, py));
      img.rgba[4 * p + 0] = cr + T * sky.x;
      img.rgba[4 * p + 1] = cg + T * sky.y;
      img.rgba[4 * p + 2] = cb + T * sky.z;
      img.rgba[4 * p + 3] = 1.0f - T;
      img.depth[2 * p + 0] = T < 1.0f ? wz / (1.0f - T) : 0.0f;
      img.depth[2 * p + 1] = median;
    }
  if (!opts.depth) img.depth.clear();
  return img;
}

SplatImage render_cpu(const GaussianCloud& cloud, const render::Camera& cam, const SplatOptions& opts) {
  const auto proj = preprocess_cpu(cloud, cam, opts);
  const SplatFrame f = make_frame(cam, opts, glm::dvec3(0.0));
  const TileBins bins = bin_cpu(proj, f.grid_x, f.grid_y, TileRule::Ellipse, opts.depth_key_bits);
  return blend_cpu(proj, bins, cam, opts);
}

}  // namespace icube::splat

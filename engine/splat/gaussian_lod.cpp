#include "splat/gaussian_lod.h"

#include "splat/splat_scene.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <numeric>
#include <stdexcept>

namespace icube::splat {

namespace {

glm::dmat3 rotation_of(const glm::vec4& q) {  // wxyz, unit
  const double w = q.x, x = q.y, y = q.z, z = q.w;
  glm::dmat3 r;  // column-major: r[col][row]
  r[0] = {1 - 2 * (y * y + z * z), 2 * (x * y + w * z), 2 * (x * z - w * y)};
  r[1] = {2 * (x * y - w * z), 1 - 2 * (x * x + z * z), 2 * (y * z + w * x)};
  r[2] = {2 * (x * z + w * y), 2 * (y * z - w * x), 1 - 2 * (x * x + y * y)};
  return r;
}

// Eigen-decomposition of a symmetric 3x3 matrix by cyclic Jacobi rotations: a = V diag(e) Vᵀ.
void jacobi_eigen(glm::dmat3 a, glm::dvec3& e, glm::dmat3& v) {
  v = glm::dmat3(1.0);
  for (int sweep = 0; sweep < 50; ++sweep) {
    const double off = a[1][0] * a[1][0] + a[2][0] * a[2][0] + a[2][1] * a[2][1];
    if (off < 1e-30) break;
    for (int p = 0; p < 2; ++p)
      for (int q = p + 1; q < 3; ++q) {
        const double apq = a[q][p];
        if (std::fabs(apq) < 1e-300) continue;
        const double theta = (a[q][q] - a[p][p]) / (2.0 * apq);
        const double t = (theta >= 0 ? 1.0 : -1.0) / (std::fabs(theta) + std::sqrt(theta * theta + 1.0));
        const double c = 1.0 / std::sqrt(t * t + 1.0), s = t * c;
        glm::dmat3 j(1.0);
        j[p][p] = c, j[q][q] = c, j[q][p] = s, j[p][q] = -s;  // column q row p = s
        a = glm::transpose(j) * a * j;
        v = v * j;
      }
  }
  e = {a[0][0], a[1][1], a[2][2]};
}

double footprint(const glm::vec3& s) {
  std::array<double, 3> v = {double(s.x), double(s.y), double(s.z)};
  std::sort(v.begin(), v.end());
  return v[1] * v[2];
}

}  // namespace

void merge_gaussians(const GaussianCloud& cloud, const std::vector<uint32_t>& idx, GaussianCloud& out) {
  if (idx.empty()) return;
  const uint32_t K = cloud.sh_coeffs();
  std::vector<float> sh(size_t(K) * 3, 0.0f);
  if (idx.size() == 1) {
    const uint32_t i = idx[0];
    out.add(cloud.positions[i], cloud.scales[i], cloud.rotations[i], cloud.opacities[i], &cloud.sh[size_t(i) * K * 3]);
    return;
  }
  double wsum = 0.0, alpha_area = 0.0;
  glm::dvec3 mu(0.0);
  std::vector<double> shd(sh.size(), 0.0);
  std::vector<double> w(idx.size());
  for (size_t k = 0; k < idx.size(); ++k) {
    const uint32_t i = idx[k];
    const double a = footprint(cloud.scales[i]);
    w[k] = std::max(1e-12, double(cloud.opacities[i]) * a);
    wsum += w[k];
    alpha_area += double(cloud.opacities[i]) * a;
    mu += w[k] * cloud.positions[i];
    for (size_t c = 0; c < shd.size(); ++c) shd[c] += w[k] * double(cloud.sh[size_t(i) * K * 3 + c]);
  }
  mu /= wsum;
  glm::dmat3 cov(0.0);
  for (size_t k = 0; k < idx.size(); ++k) {
    const uint32_t i = idx[k];
    const glm::dmat3 r = rotation_of(cloud.rotations[i]);
    const glm::dvec3 s(cloud.scales[i]);
    const glm::dmat3 ci = r * glm::dmat3(s.x * s.x, 0, 0, 0, s.y * s.y, 0, 0, 0, s.z * s.z) * glm::transpose(r);
    const glm::dvec3 d = cloud.positions[i] - mu;
    cov += w[k] * (ci + glm::outerProduct(d, d));
  }
  cov /= wsum;
  glm::dvec3 ev;
  glm::dmat3 V;
  jacobi_eigen(cov, ev, V);
  if (glm::determinant(V) < 0.0) V[2] = -V[2];
  const glm::vec3 scale(float(std::sqrt(std::max(ev.x, 1e-12))), float(std::sqrt(std::max(ev.y, 1e-12))),
                        float(std::sqrt(std::max(ev.z, 1e-12))));
  const glm::dvec4 q = quaternion_from_rotation(V);
  const float opacity = float(std::min(0.99, alpha_area / std::max(1e-12, footprint(scale))));
  for (size_t c = 0; c < sh.size(); ++c) sh[c] = float(shd[c] / wsum);
  out.add(mu, scale, glm::vec4(q), opacity, sh.data());
}

ChunkedGaussians build_gaussian_chunks(const GaussianCloud& cloud, const GaussianChunkOptions& o) {
  if (!(o.chunk_size > 0.0) || !(o.merge_cell > 0.0))
    throw std::invalid_argument("gaussian chunks: chunk_size and merge_cell must be positive");
  ChunkedGaussians out;
  out.options = o;
  out.fine.sh_degree = out.coarse.sh_degree = cloud.sh_degree;
  const uint32_t K = cloud.sh_coeffs();
  std::map<std::pair<int64_t, int64_t>, std::vector<uint32_t>> by_chunk;
  for (uint32_t i = 0; i < cloud.size(); ++i)
    by_chunk[{int64_t(std::floor(cloud.positions[i].x / o.chunk_size)),
              int64_t(std::floor(cloud.positions[i].y / o.chunk_size))}]
        .push_back(i);
  for (const auto& [key, members] : by_chunk) {
    GaussianChunk ch;
    ch.first = uint32_t(out.fine.size());
    ch.count = uint32_t(members.size());
    ch.lo = glm::dvec3(1e300);
    ch.hi = glm::dvec3(-1e300);
    std::map<std::array<int64_t, 3>, std::vector<uint32_t>> groups;
    for (uint32_t i : members) {
      out.fine.add(cloud.positions[i], cloud.scales[i], cloud.rotations[i], cloud.opacities[i], &cloud.sh[size_t(i) * K * 3]);
      const glm::vec3& s = cloud.scales[i];
      const double r = 3.0 * double(std::max({s.x, s.y, s.z}));
      ch.lo = glm::min(ch.lo, cloud.positions[i] - r);
      ch.hi = glm::max(ch.hi, cloud.positions[i] + r);
      const glm::dvec3 g = glm::floor(cloud.positions[i] / o.merge_cell);
      groups[{int64_t(g.x), int64_t(g.y), int64_t(g.z)}].push_back(i);
    }
    ch.coarse_first = uint32_t(out.coarse.size());
    for (const auto& [gk, idx] : groups) merge_gaussians(cloud, idx, out.coarse);
    ch.coarse_count = uint32_t(out.coarse.size()) - ch.coarse_first;
    // The coarse Gaussians' extents may reach beyond the fine ones'.
    for (uint32_t j = ch.coarse_first; j < out.coarse.size(); ++j) {
      const glm::vec3& s = out.coarse.scales[j];
      const double r = 3.0 * double(std::max({s.x, s.y, s.z}));
      ch.lo = glm::min(ch.lo, out.coarse.positions[j] - r);
      ch.hi = glm::max(ch.hi, out.coarse.positions[j] + r);
    }
    out.chunks.push_back(ch);
  }
  return out;
}

bool box_outside_view(const glm::dvec3& lo, const glm::dvec3& hi, const render::Camera& cam, double near_plane,
                      double margin_px) {
  const glm::dmat4 w2c = glm::inverse(cam.c2w);
  std::array<glm::dvec3, 8> c;
  for (int k = 0; k < 8; ++k)
    c[size_t(k)] = glm::dvec3(w2c * glm::dvec4(k & 1 ? hi.x : lo.x, k & 2 ? hi.y : lo.y, k & 4 ? hi.z : lo.z, 1.0));
  // Side planes through the camera centre: x >= (−cx − m)/fx · z etc. (x right, y down, z forward).
  const double xl = (-cam.K.cx - margin_px) / cam.K.fx, xr = (double(cam.K.width) - cam.K.cx + margin_px) / cam.K.fx;
  const double yt = (-cam.K.cy - margin_px) / cam.K.fy, yb = (double(cam.K.height) - cam.K.cy + margin_px) / cam.K.fy;
  auto all = [&](auto outside) {
    for (const glm::dvec3& p : c)
      if (!outside(p)) return false;
    return true;
  };
  return all([&](const glm::dvec3& p) { return p.z < near_plane; }) ||
         all([&](const glm::dvec3& p) { return p.x < xl * p.z; }) ||
         all([&](const glm::dvec3& p) { return p.x > xr * p.z; }) ||
         all([&](const glm::dvec3& p) { return p.y < yt * p.z; }) ||
         all([&](const glm::dvec3& p) { return p.y > yb * p.z; });
}

ChunkedGaussians single_chunk(GaussianCloud cloud) {
  ChunkedGaussians c;
  c.coarse.sh_degree = cloud.sh_degree;
  GaussianChunk ch;
  ch.count = static_cast<uint32_t>(cloud.size());
  if (cloud.size() > UINT32_MAX) throw std::invalid_argument("splat: too many Gaussians for one chunk");
  for (size_t i = 0; i < cloud.size(); ++i) {
    const glm::dvec3 e(3.0 * double(std::max({cloud.scales[i].x, cloud.scales[i].y, cloud.scales[i].z})));
    ch.lo = i ? glm::min(ch.lo, cloud.positions[i] - e) : cloud.positions[i] - e;
    ch.hi = i ? glm::max(ch.hi, cloud.positions[i] + e) : cloud.positions[i] + e;
  }
  c.fine = std::move(cloud);
  c.chunks.push_back(ch);
  c.options.chunk_size = 0.0;
  return c;
}

LodPicks pick_chunks(const std::vector<GaussianChunk>& chunks, const render::Camera& cam, const LodOptions& o) {
  LodPicks p;
  const glm::dvec3 eye(cam.c2w[3]);
  for (uint32_t i = 0; i < chunks.size(); ++i) {
    const GaussianChunk& ch = chunks[i];
    const double dist = glm::length(glm::clamp(eye, ch.lo, ch.hi) - eye);
    if ((o.max_distance > 0.0 && dist > o.max_distance) ||
        (o.frustum && box_outside_view(ch.lo, ch.hi, cam, o.near_plane, o.margin_px))) {
      ++p.chunks_out;
      continue;
    }
    const bool coarse = o.coarse_distance > 0.0 && dist > o.coarse_distance;
    p.picks.push_back({i, coarse});
    ++(coarse ? p.chunks_coarse : p.chunks_fine);
  }
  return p;
}

LodSelection select_gaussians(const ChunkedGaussians& c, const render::Camera& cam, const LodOptions& o) {
  LodSelection sel;
  sel.cloud.sh_degree = c.fine.sh_degree;
  const uint32_t K = c.fine.sh_coeffs();
  auto append = [&](const GaussianCloud& src, uint32_t first, uint32_t count) {
    for (uint32_t i = first; i < first + count; ++i)
      sel.cloud.add(src.positions[i], src.scales[i], src.rotations[i], src.opacities[i], &src.sh[size_t(i) * K * 3]);
  };
  const LodPicks p = pick_chunks(c.chunks, cam, o);
  for (const ChunkPick& k : p.picks) {
    const GaussianChunk& ch = c.chunks[k.chunk];
    if (k.coarse) append(c.coarse, ch.coarse_first, ch.coarse_count);
    else append(c.fine, ch.first, ch.count);
  }
  sel.chunks_fine = p.chunks_fine;
  sel.chunks_coarse = p.chunks_coarse;
  sel.chunks_out = p.chunks_out;
  return sel;
}

}  // namespace icube::splat

// LiDAR on Gaussians, CPU reference; see lidar_gaussians_cpu.h.
#include "splat/lidar_gaussians_cpu.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <stdexcept>
#include <thread>

namespace icube::splat {

LidarGaussian lidar_gaussian(const glm::dvec3& mean, const glm::vec3& scale, const glm::vec4& q, float opacity,
                             float intensity) {
  const double r = q.x, x = q.y, y = q.z, z = q.w;  // (w, x, y, z) in x..w
  const double R[3][3] = {{1 - 2 * (y * y + z * z), 2 * (x * y - r * z), 2 * (x * z + r * y)},
                          {2 * (x * y + r * z), 1 - 2 * (x * x + z * z), 2 * (y * z - r * x)},
                          {2 * (x * z - r * y), 2 * (y * z + r * x), 1 - 2 * (x * x + y * y)}};
  LidarGaussian g;
  g.mean = mean;
  double smax = 0.0;
  for (int i = 0; i < 3; ++i) {
    const double s = std::max(static_cast<double>(scale[i]), kLidarMinScale);
    smax = std::max(smax, s);
    // Row i of W = column i of R over s_i; glm stores columns: W[col][row].
    for (int c = 0; c < 3; ++c) g.W[c][i] = R[c][i] / s;
  }
  g.opacity = static_cast<double>(opacity);
  g.intensity = static_cast<double>(intensity);
  const double o255 = 255.0 * g.opacity;
  g.r_cut = o255 > 1.0 ? smax * std::sqrt(2.0 * std::log(o255)) : 0.0;
  return g;
}

GaussianCloud lidar_range_subset(const GaussianCloud& cloud, const glm::dvec3& sensor, double max_range) {
  GaussianCloud out;
  out.sh_degree = cloud.sh_degree;
  const size_t stride = size_t{cloud.sh_coeffs()} * 3;
  for (size_t i = 0; i < cloud.size(); ++i) {
    const LidarGaussian g = lidar_gaussian(cloud.positions[i], cloud.scales[i], cloud.rotations[i], cloud.opacities[i], 0.0f);
    if (g.r_cut <= 0.0 || glm::length(cloud.positions[i] - sensor) - (1.01 * g.r_cut + 1e-3) > max_range) continue;
    out.add(cloud.positions[i], cloud.scales[i], cloud.rotations[i], cloud.opacities[i], &cloud.sh[i * stride]);
  }
  return out;
}

std::vector<float> lidar_gaussian_intensity(const GaussianCloud& cloud) {
  std::vector<float> out(cloud.size(), 0.0f);
  const size_t stride = size_t{cloud.sh_coeffs()} * 3;
  if (cloud.sh.size() < cloud.size() * stride) throw std::invalid_argument("lidar gaussians: SH array too short");
  for (size_t i = 0; i < cloud.size(); ++i) {
    const float* dc = &cloud.sh[i * stride];
    double rgb[3];
    for (int c = 0; c < 3; ++c) rgb[c] = std::max(0.0, kShC0 * static_cast<double>(dc[c]) + 0.5);
    const double lum = 0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2];
    out[i] = static_cast<float>(std::clamp(lum, 0.0, 1.0));
  }
  return out;
}

RayGaussianResponse ray_gaussian_response(const LidarGaussian& g, const glm::dvec3& m, const glm::dvec3& d) {
  const glm::dvec3 mw = g.W * m, dw = g.W * d;
  const double a = glm::dot(dw, dw);
  RayGaussianResponse r;
  r.t = glm::dot(dw, mw) / a;
  const glm::dvec3 c = glm::cross(mw, dw);
  r.q2 = glm::dot(c, c) / a;
  r.G = std::exp(-0.5 * r.q2);
  r.alpha = std::min(kLidarMaxAlpha, g.opacity * r.G);
  return r;
}

namespace {

struct Candidate {
  double t, alpha, intensity;
  uint32_t index;
};

shader::SplatLidarHit composite(std::vector<Candidate>& cand) {
  std::sort(cand.begin(), cand.end(), [](const Candidate& a, const Candidate& b) {
    return a.t < b.t || (a.t == b.t && a.index < b.index);
  });
  double T = 1.0, wt = 0.0, wi = 0.0, median = 0.0;
  shader::SplatLidarHit h{};
  for (const Candidate& c : cand) {
    const double test_t = T * (1.0 - c.alpha);
    if (test_t < kLidarStopT) {
      h.flags |= SPLAT_LIDAR_FLAG_STOPPED;
      break;
    }
    const double w = c.alpha * T;
    wt += w * c.t;
    wi += w * c.intensity;
    if (T > 0.5 && test_t <= 0.5) {
      median = c.t;
      h.flags |= SPLAT_LIDAR_FLAG_MEDIAN;
    }
    T = test_t;
    ++h.count;
  }
  const double a = 1.0 - T;
  h.alpha = static_cast<float>(a);
  h.t_expected = a > 0.0 ? static_cast<float>(wt / a) : 0.0f;
  h.t_median = static_cast<float>(median);
  h.intensity = a > 0.0 ? static_cast<float>(wi / a) : 0.0f;
  return h;
}

}  // namespace

std::vector<shader::SplatLidarHit> cast_lidar_gaussians_cpu(const GaussianCloud& cloud,
                                                           const std::vector<float>& intensity,
                                                           const render::LidarModel& model,
                                                           const glm::dmat4& s2w, unsigned threads,
                                                           const std::vector<uint32_t>& rays) {
  render::validate_lidar(model);
  if (intensity.size() != cloud.size()) throw std::invalid_argument("lidar gaussians: one intensity per Gaussian");
  std::vector<LidarGaussian> gs;
  gs.reserve(cloud.size());
  for (size_t i = 0; i < cloud.size(); ++i)
    gs.push_back(lidar_gaussian(cloud.positions[i], cloud.scales[i], cloud.rotations[i], cloud.opacities[i],
                                intensity[i]));
  const std::vector<glm::dvec3> dirs = render::lidar_directions(model);
  const glm::dmat3 R(s2w);
  const glm::dvec3 o(s2w[3]);
  std::vector<shader::SplatLidarHit> hits(dirs.size(), shader::SplatLidarHit{});
  for (uint32_t r : rays)
    if (r >= dirs.size()) throw std::invalid_argument("lidar gaussians: ray index out of range");
  const size_t count = rays.empty() ? dirs.size() : rays.size();
  std::atomic<size_t> next{0};
  auto work = [&] {
    std::vector<Candidate> cand;
    for (;;) {
      const size_t j0 = next.fetch_add(64);
      if (j0 >= count) return;
      for (size_t j = j0; j < std::min(count, j0 + 64); ++j) {
        const size_t ray = rays.empty() ? j : rays[j];
        const glm::dvec3 d = glm::normalize(R * dirs[ray]);
        cand.clear();
        for (size_t i = 0; i < gs.size(); ++i) {
          const LidarGaussian& g = gs[i];
          if (g.r_cut <= 0.0) continue;
          const glm::dvec3 m = g.mean - o;
          // Cheap exact rejection: the peak point lies within r_cut of μ, so the ray line must pass that close.
          const glm::dvec3 x = glm::cross(m, d);
          if (glm::dot(x, x) > g.r_cut * g.r_cut * (1.0 + 1e-9)) continue;
          const RayGaussianResponse resp = ray_gaussian_response(g, m, d);
          if (!(resp.alpha >= kLidarMinAlpha) || resp.t < model.min_range || resp.t > model.max_range) continue;
          cand.push_back({resp.t, resp.alpha, g.intensity, static_cast<uint32_t>(i)});
        }
        hits[ray] = composite(cand);
      }
    }
  };
  if (threads == 0) threads = std::max(1u, std::thread::hardware_concurrency());
  threads = static_cast<unsigned>(std::min<size_t>(threads, std::max<size_t>(1, count / 64)));
  if (threads <= 1) {
    work();
  } else {
    std::vector<std::thread> pool;
    for (unsigned k = 0; k < threads; ++k) pool.emplace_back(work);
    for (auto& t : pool) t.join();
  }
  return hits;
}

render::LidarScan lidar_scan_from_gaussian_hits(const render::LidarModel& m, const std::vector<glm::dvec3>& dirs,
                                                const glm::dmat4& s2w,
                                                const std::vector<shader::SplatLidarHit>& hits,
                                                const LidarGaussianOptions& opts) {
  if (dirs.size() != m.rays() || hits.size() != m.rays())
    throw std::invalid_argument("lidar gaussians: hit or direction count differs from beams x columns");
  if (!(opts.alpha_threshold > 0.0 && opts.alpha_threshold <= 1.0))
    throw std::invalid_argument("lidar gaussians: the alpha threshold must be in (0, 1]");
  render::LidarScan s;
  s.sensor_to_world = s2w;
  s.beams = m.beams();
  s.columns = m.columns;
  s.range.assign(hits.size(), 0.0f);
  for (size_t i = 0; i < hits.size(); ++i) {
    const shader::SplatLidarHit& h = hits[i];
    if (h.count == 0 || !(static_cast<double>(h.alpha) >= opts.alpha_threshold)) continue;
    const bool median = opts.range == LidarRangeMode::Median && (h.flags & SPLAT_LIDAR_FLAG_MEDIAN);
    // Every contributing t* lies in [min_range, max_range]; clamp only the float rounding of the average.
    const float range = std::clamp(median ? h.t_median : h.t_expected, static_cast<float>(m.min_range),
                                   static_cast<float>(m.max_range));
    render::LidarReturn r;
    const glm::dvec3 ps = static_cast<double>(range) * dirs[i];
    r.sensor = glm::vec3(ps);
    r.world = glm::dvec3(s2w * glm::dvec4(ps, 1.0));
    r.range = range;
    r.intensity = std::clamp(h.intensity, 0.0f, 1.0f);
    r.ring = static_cast<uint16_t>(i / m.columns);
    r.column = static_cast<uint16_t>(i % m.columns);
    s.range[i] = range;
    s.returns.push_back(r);
  }
  return s;
}

}  // namespace icube::splat

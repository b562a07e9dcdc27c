// icube-bench-splat: the GPU Gaussian splatting rasterizer (engine/splat/,
// shaders/splat_*.comp) on random scenes: frames per second and GPU time by
// phase (preprocess; depth sort of the Gaussians + tile counts in depth order
// + scan; binning by tile: duplicate tile ids + radix sort by tile + ranges,
// or the counting sort of tile_binning_gpu.h; blend), tile
// instances per frame and GPU memory per Gaussian, for every
// (Gaussian count, resolution) pair; and the CPU reference's frame time for
// the smallest case as the competing implementation.
//
// Scene: --gaussians N random Gaussians (SH degree --sh, default 3) in a
// 20 × 20 × 6 m box, log-uniform scales 2–20 cm (fixed seed), opacity U(0,1);
// the camera 14 m back and 4 m up looking at the box centre, focal 0.8·W.
// min / median of --runs after --warmup; fps from the median wall time of a
// whole frame (both submissions, one CPU sync, no image readback).
// Pipeline variants side by side (--variants, SplatGpuVariant): "rect-rows"
// (whole getRect rects + the previous row blend, splat/blend_rows.comp),
// "cull-rows", "rect-tile" and "cull-tile" (exact tile culling + one tile per
// workgroup, the default); all four bin with the device's default
// (SplatGpuVariant::binning Auto: the counting sort of tile_binning_gpu.h on
// CPU devices, the radix path on GPUs), "cull-tile-radix" and
// "cull-tile-counting" force one ("cull-tile-counting-C": with C chunks). Their
// runs alternate, so they share the load. A "-color" suffix (e.g.
// "cull-tile-color") renders without the depth outputs (SplatOptions::depth =
// false: splat_blend's pipeline without them), as `icube splat render` does
// without --depth.
// A "-slices-N" suffix (before -color) blends frames of more than N Gaussians in depth
// slices of at most N (SplatGpuVariant::max_pass_gaussians); frames over the device's one pass
// (lavapipe: 2.79 M Gaussians) are sliced by every variant ("slices" column).
// Check in the same run: each variant's image against the first variant's
// (max |difference| over RGBA, and depth where both have it; slicings agree bit for bit).
//
//   LP_NUM_THREADS=2 icube-bench-splat [--gaussians 100000,1000000] [--sizes 1280x720,1920x1080] [--runs 5]
//       [--variants rect-rows,cull-tile]
#include "bench_host.h"
#include "gpu/context.h"
#include "splat/rasterizer_cpu.h"
#include "splat/rasterizer_gpu.h"

#include <CLI/CLI.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <random>
#include <stdexcept>
#include <sstream>
#include <string>
#include <vector>

using namespace icube;

namespace {

splat::GaussianCloud make_scene(size_t n, uint32_t degree, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0), u01(0.0, 1.0);
  std::normal_distribution<double> nd(0.0, 1.0);
  splat::GaussianCloud c;
  c.sh_degree = degree;
  std::vector<float> coeffs(c.sh_coeffs() * 3);
  c.positions.reserve(n);
  for (size_t i = 0; i < n; ++i) {
    const glm::dvec3 p(10.0 * u(rng), 10.0 * u(rng), 3.0 * u(rng));
    glm::vec3 s;
    for (int k = 0; k < 3; ++k) s[k] = static_cast<float>(std::exp(std::log(0.02) + std::log(10.0) * u01(rng)));
    glm::dvec4 q(nd(rng), nd(rng), nd(rng), nd(rng));
    q /= glm::length(q);
    for (size_t k = 0; k < coeffs.size(); ++k) coeffs[k] = static_cast<float>((k < 3 ? 1.5 : 0.2) * u(rng));
    c.add(p, s, glm::vec4(q), static_cast<float>(u01(rng)), coeffs.data());
  }
  return c;
}

render::Camera make_camera(uint32_t w, uint32_t h) {
  const glm::dvec3 eye(0.0, -14.0, 4.0), target(0.0, 0.0, 0.0);
  const glm::dvec3 z = glm::normalize(target - eye);
  const glm::dvec3 x = glm::normalize(glm::cross(z, glm::dvec3(0.0, 0.0, 1.0)));
  const glm::dvec3 y = glm::cross(z, x);
  render::Camera c;
  c.K = {0.8 * w, 0.8 * w, 0.5 * w, 0.5 * h, w, h};
  c.c2w = glm::dmat4(glm::dvec4(x, 0.0), glm::dvec4(y, 0.0), glm::dvec4(z, 0.0), glm::dvec4(eye, 1.0));
  return c;
}

template <class T>
std::vector<T> parse_list(const std::string& s) {
  std::vector<T> out;
  std::stringstream in(s);
  std::string tok;
  while (std::getline(in, tok, ',')) out.push_back(static_cast<T>(std::stod(tok)));
  return out;
}

struct Variant {
  std::string name;
  splat::SplatGpuVariant v;
  bool depth = true;  // SplatOptions::depth
};

Variant parse_pipeline(const std::string& s) {
  const size_t sl = s.find("-slices-");
  if (sl != std::string::npos) {  // depth slices of at most N Gaussians (SplatGpuVariant::max_pass_gaussians)
    Variant v = parse_pipeline(s.substr(0, sl));
    v.name = s;
    v.v.max_pass_gaussians = std::stoull(s.substr(sl + 8));
    return v;
  }
  if (s == "rect-rows") return {s, {false, false}};
  if (s == "cull-rows") return {s, {true, false}};
  if (s == "rect-tile") return {s, {false, true}};
  if (s == "cull-tile") return {s, {true, true}};
  if (s == "cull-tile-radix") return {s, {true, true, splat::TileBinning::Radix}};
  if (s == "cull-tile-counting") return {s, {true, true, splat::TileBinning::Counting}};
  if (s.rfind("cull-tile-counting-", 0) == 0)  // forced chunk count (SplatGpuVariant::bin_chunks)
    return {s, {true, true, splat::TileBinning::Counting, static_cast<uint32_t>(std::stoul(s.substr(19)))}};
  throw std::invalid_argument("--variants: unknown variant '" + s +
                              "' (rect-rows, cull-rows, rect-tile, cull-tile, cull-tile-radix, cull-tile-counting[-CHUNKS], each with "
                              "optional -slices-N and -color suffixes)");
}

// A pipeline name with an optional "-color" suffix (no depth outputs).
Variant parse_variant(const std::string& s) {
  const std::string suffix = "-color";
  if (s.size() > suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0) {
    Variant v = parse_pipeline(s.substr(0, s.size() - suffix.size()));
    v.name = s;
    v.depth = false;
    return v;
  }
  return parse_pipeline(s);
}

double max_diff(const splat::SplatImage& a, const splat::SplatImage& b) {
  double d = 0.0;
  for (size_t i = 0; i < a.rgba.size(); ++i) d = std::max(d, std::fabs(double(a.rgba[i]) - double(b.rgba[i])));
  for (size_t i = 0; i < std::min(a.depth.size(), b.depth.size()); ++i) d = std::max(d, std::fabs(double(a.depth[i]) - double(b.depth[i])));
  return d;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v[v.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app("icube-bench-splat: GPU Gaussian splatting frames per second by phase");
  std::string gaussians = "100000,1000000", sizes = "1280x720,1920x1080", variants = "rect-rows,cull-tile";
  int runs = 5, warmup = 1;
  uint32_t sh = 3;
  bool cpu = true;
  app.add_option("--gaussians", gaussians, "Comma-separated Gaussian counts")->capture_default_str();
  app.add_option("--sizes", sizes, "Comma-separated WxH")->capture_default_str();
  app.add_option("--runs", runs)->capture_default_str();
  app.add_option("--warmup", warmup)->capture_default_str();
  app.add_option("--sh", sh, "SH degree 0-3")->capture_default_str();
  app.add_option("--variants", variants,
                 "Comma-separated pipeline variants: rect-rows, cull-rows, rect-tile, cull-tile, cull-tile-radix, "
                 "cull-tile-counting, cull-tile-counting-CHUNKS; a -slices-N suffix slices frames over N Gaussians, "
                 "a -color suffix leaves the depth outputs out")
      ->capture_default_str();
  app.add_flag("!--no-cpu", cpu, "Skip the CPU reference row");
  CLI11_PARSE(app, argc, argv);
  std::vector<Variant> vars;
  try {
    std::stringstream in(variants);
    std::string t;
    while (std::getline(in, t, ',')) vars.push_back(parse_variant(t));
    if (vars.empty()) throw std::invalid_argument("--variants: empty list");
  } catch (const std::exception& e) {
    std::fprintf(stderr, "icube-bench-splat: %s\n", e.what());
    return 2;
  }

  gpu::Context ctx(gpu::ContextOptions::from_env());
  std::printf("icube-bench-splat: device %s, subgroup %u, CPU %s (%u CPUs), LP_NUM_THREADS=%s\n",
              ctx.info().name.c_str(), ctx.subgroup_size(), bench::cpu_model().c_str(), bench::online_cpus(),
              bench::env_or_unset("LP_NUM_THREADS").c_str());
  std::printf("%10s %10s %26s %7s %8s %8s %8s %8s %8s %8s %8s %9s %11s %6s %8s %9s %9s\n", "gaussians", "size",
              "variant", "fps", "min ms", "med ms", "CPU ms", "pre ms", "dsort ms", "tsort ms", "blend ms", "blend min",
              "instances", "slices", "B/Gauss", "other CPU", "max diff");
  std::vector<std::unique_ptr<splat::SplatRendererGpu>> renderers;
  for (const Variant& v : vars) renderers.push_back(std::make_unique<splat::SplatRendererGpu>(ctx, v.v));
  for (const size_t n : parse_list<size_t>(gaussians)) {
    const splat::GaussianCloud cloud = make_scene(n, sh, 42);
    const splat::GpuGaussians g = renderers[0]->upload(cloud);
    for (const std::string& sz : [&] {
           std::vector<std::string> v;
           std::stringstream in(sizes);
           std::string t;
           while (std::getline(in, t, ',')) v.push_back(t);
           return v;
         }()) {
      const size_t xpos = sz.find('x');
      const uint32_t w = static_cast<uint32_t>(std::stoul(sz.substr(0, xpos)));
      const uint32_t h = static_cast<uint32_t>(std::stoul(sz.substr(xpos + 1)));
      const render::Camera cam = make_camera(w, h);
      std::vector<splat::SplatOptions> opts(vars.size());
      for (size_t k = 0; k < vars.size(); ++k) opts[k].depth = vars[k].depth;
      const size_t V = vars.size();
      std::vector<splat::SplatTimings> t(V);
      std::vector<double> diff(V, 0.0);
      try {
        // First frame of each variant: JIT, buffers, and the image for the check.
        splat::SplatImage first;
        for (size_t k = 0; k < V; ++k) {
          const splat::SplatImage img = renderers[k]->render(g, cam, opts[k], &t[k]);
          if (k == 0) first = img;
          else diff[k] = max_diff(img, first);
        }
      } catch (const std::exception& e) {
        std::printf("%10zu %10s   not rendered: %s\n", n, sz.c_str(), e.what());
        continue;
      }
      for (int i = 0; i < warmup; ++i)
        for (size_t k = 0; k < V; ++k) renderers[k]->render(g, cam, opts[k], &t[k], nullptr, false);
      std::vector<std::vector<double>> wall(V), pre(V), dsort(V), sort(V), blend(V), own(V);
      const bench::CpuTimes c0 = bench::cpu_times_now();
      for (int i = 0; i < runs; ++i)
        for (size_t k = 0; k < V; ++k) {  // alternate the variants: they share the load
          const double own0 = bench::cpu_times_now().own_s;
          renderers[k]->render(g, cam, opts[k], &t[k], nullptr, false);
          own[k].push_back(1e3 * (bench::cpu_times_now().own_s - own0));
          wall[k].push_back(t[k].wall_ms);
          pre[k].push_back(t[k].preprocess_ms);
          dsort[k].push_back(t[k].depth_sort_ms);
          sort[k].push_back(t[k].sort_ms);
          blend[k].push_back(t[k].blend_ms);
        }
      const double other = bench::other_cpu_seconds(c0, bench::cpu_times_now());
      for (size_t k = 0; k < V; ++k) {
        const double bytes_per = static_cast<double>(g.bytes() + t[k].frame_bytes) / static_cast<double>(n);
        std::printf("%10zu %10s %26s %7.2f %8.1f %8.1f %8.1f %8.1f %8.1f %8.1f %8.1f %9.1f %11llu %6u %8.0f %8.1fs %9.2g\n",
                    n, sz.c_str(), vars[k].name.c_str(), 1000.0 / median(wall[k]),
                    *std::min_element(wall[k].begin(), wall[k].end()), median(wall[k]), median(own[k]), median(pre[k]),
                    median(dsort[k]), median(sort[k]), median(blend[k]),
                    *std::min_element(blend[k].begin(), blend[k].end()),
                    static_cast<unsigned long long>(t[k].instances), t[k].slices, bytes_per, other, diff[k]);
      }
      std::fflush(stdout);
    }
  }
  if (cpu) {
    const size_t n = parse_list<size_t>(gaussians).front();
    const splat::GaussianCloud cloud = make_scene(n, sh, 42);
    const render::Camera cam = make_camera(1280, 720);
    const auto t0 = std::chrono::steady_clock::now();
    const auto img = splat::render_cpu(cloud, cam, splat::SplatOptions{});
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    std::printf("CPU reference (1 thread, float, same rules): %zu Gaussians 1280x720: %.1f ms/frame (%.2f fps)\n", n,
                ms, 1000.0 / ms);
    (void)img;
  }
  std::printf("pre: preprocess; dsort: depth sort of the Gaussians (32-bit keys) + tile counts in depth order (exact "
              "tile culling) + scan; tsort: tile ids in depth order + stable radix sort by tile + ranges (radix "
              "binning) or count walk + per-tile offsets and ranges + emit walk (counting binning).\n");
  std::printf("B/Gauss: static (Gaussian records + SH) plus the frame buffers (projections, rects, counts, keys, "
              "sort scratch, image) divided by the Gaussian count; other CPU: CPU time other processes used during "
              "the timed runs of the row; CPU ms: median CPU time this process (lavapipe's threads) used per frame, which load "
              "from other processes inflates far less than wall time; max diff: max |image - first variant's image| (RGBA, depth).\n");
  return 0;
}

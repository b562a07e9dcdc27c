// The GPU-vs-CPU comparison of the splatting tests (test_splat.cpp,
// test_splat_sky.cpp): one scene and camera through SplatRendererGpu with the
// stage debug copies and through the CPU reference, checked stage by stage
// (projections, per-Gaussian tile counts, tile lists up to depth ties, ranges,
// pixels, the median-depth boundary band), with counts for the report.
#pragma once

#include <doctest/doctest.h>

#include "gpu_test_context.h"
#include "splat/rasterizer_cpu.h"
#include "splat/rasterizer_gpu.h"
#include "test_splat_util.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

namespace icube::test {

using splat::SplatOptions;


// One renderer per test case (it must not outlive the shared context).
struct Renderer {
  splat::SplatRendererGpu r{test::gpu_context()};
};

inline bool close(float got, float want, double atol, double rtol) {
  return std::fabs(double(got) - double(want)) <= atol + rtol * std::fabs(double(want));
}

struct Compare {
  size_t visible = 0, instances = 0, band = 0, pixels = 0, equal_keys = 0;
  size_t swapped = 0;  // list entries where the GPU's order differs from the CPU's by a depth tie
  double max_interior = 0.0;
  double band_median = 0.0;  // largest relative median-depth error inside the band
};

// GPU vs CPU for one scene and camera; returns counts for reporting.
inline Compare compare(splat::SplatRendererGpu& gpu, const splat::GaussianCloud& cloud, const render::Camera& cam,
                const SplatOptions& opts, double band_fraction_max = 0.002,
                splat::TileRule rule = splat::TileRule::Ellipse) {
  Compare r;
  const splat::GpuGaussians g = gpu.upload(cloud);
  splat::SplatDebug dbg;
  const splat::SplatImage gi = gpu.render(g, cam, opts, nullptr, &dbg);
  const auto proj = splat::preprocess_cpu(cloud, cam, opts);
  const auto f = splat::make_frame(cam, opts, glm::dvec3(0.0));
  const auto bins = splat::bin_cpu(proj, f.grid_x, f.grid_y, rule, opts.depth_key_bits);

  REQUIRE(dbg.proj.size() == proj.size());
  size_t bad = 0, radius_steps = 0;
  for (size_t i = 0; i < proj.size(); ++i) {
    const auto& a = dbg.proj[i];
    const auto& b = proj[i];
    // The radius is ceil(3σ) of the 2-D covariance: where 3σ lands within float rounding of an
    // integer (42000 in the degenerate set) a device whose sqrt or FMA rounds differently from the
    // CPU's double gives the next integer. One step is allowed there, counted and bounded below.
    const bool ceil_step = a.radius > 0 && b.radius > 0 && std::fabs(double(a.radius) - double(b.radius)) == 1.0;
    if (ceil_step) ++radius_steps;
    if ((a.radius > 0) != (b.radius > 0) || (a.radius != b.radius && !ceil_step)) {
      if (bad++ < 5) std::printf("  Gaussian %zu: radius gpu %g cpu %g\n", i, double(a.radius), double(b.radius));
      continue;
    }
    if (b.radius <= 0) continue;
    ++r.visible;
    const bool ok = close(a.mean_x, b.mean_x, 1e-4, 1e-4) && close(a.mean_y, b.mean_y, 1e-4, 1e-4) &&
                    close(a.depth, b.depth, 1e-4, 1e-4) && close(a.conic_x, b.conic_x, 1e-4, 1e-4) &&
                    close(a.conic_y, b.conic_y, 1e-4, 1e-4) && close(a.conic_z, b.conic_z, 1e-4, 1e-4) &&
                    close(a.opacity, b.opacity, 1e-5, 1e-4) && close(a.r, b.r, 1e-4, 1e-4) &&
                    close(a.g, b.g, 1e-4, 1e-4) && close(a.b, b.b, 1e-4, 1e-4);
    if (!ok && bad++ < 5)
      std::printf("  Gaussian %zu: mean (%g %g | %g %g) depth %g|%g conic (%g %g %g | %g %g %g)\n", i,
                  double(a.mean_x), double(a.mean_y), double(b.mean_x), double(b.mean_y), double(a.depth),
                  double(b.depth), double(a.conic_x), double(a.conic_y), double(a.conic_z), double(b.conic_x),
                  double(b.conic_y), double(b.conic_z));
  }
  INFO("splat/preprocess.comp: radii, means, conics, depths, opacities, colours");
  CHECK(bad == 0);
  CHECK(radius_steps <= 1 + r.visible / 100);
  r.instances = bins.keys.size();
  // Tile-intersection lists: the (tile, Gaussian) sequence must be identical. The depth
  // word of the key is the float view z, compared within 1e-4 above (CPU: μ − camera in
  // double; GPU: float positions relative to the scene origin), so equal keys are not required.
  std::vector<uint32_t> gt(dbg.keys.size()), ct(bins.keys.size());
  for (size_t i = 0; i < gt.size(); ++i) gt[i] = static_cast<uint32_t>(dbg.keys[i] >> 32);
  for (size_t i = 0; i < ct.size(); ++i) ct[i] = static_cast<uint32_t>(bins.keys[i] >> 32);
  // splat/sorted_counts.comp: each Gaussian's tiles touched, in depth order, scanned into the
  // duplicate offsets: every visible Gaussian appears exactly tile_count() times (exact tile culling).
  {
    std::vector<uint32_t> seen(proj.size(), 0);
    for (uint32_t v : dbg.values)
      if (v < seen.size()) ++seen[v];
    size_t bad_counts = 0;
    for (size_t i = 0; i < proj.size(); ++i) {
      // The GPU's own projection: sorted_counts must bin what preprocess produced.
      const uint32_t want = splat::tile_count(dbg.proj[i], f.grid_x, f.grid_y, rule);
      if (seen[i] != want && bad_counts++ < 5) std::printf("  Gaussian %zu: %u instances, want %u\n", i, seen[i], want);
    }
    INFO("splat/preprocess.comp tile counts + splat/sorted_counts.comp + scan: instances per Gaussian = the tiles "
         "its α-cut ellipse reaches (tile_count)");
    CHECK(bad_counts == 0);
  }
  INFO("splat/duplicate.comp + stable tile-id radix sort: the sorted (tile, Gaussian) list");
  CHECK(test::equal_report(gt, ct, "key tile ids"));
  size_t same_keys = 0;
  for (size_t i = 0; i < std::min(dbg.keys.size(), bins.keys.size()); ++i) same_keys += dbg.keys[i] == bins.keys[i];
  r.equal_keys = same_keys;
  // The Gaussians per tile in the same order, except that two whose depths tie within the
  // preprocess tolerance above may swap (the GPU's float depths are rounded differently from
  // the CPU's; drivers that contract a·b + c into an FMA, as NVIDIA's does, round differently again).
  size_t order_bad = 0, swapped = 0;
  for (size_t k = 0; k < std::min(dbg.values.size(), bins.values.size()); ++k) {
    const uint32_t a = dbg.values[k], b = bins.values[k];
    if (a == b) continue;
    ++swapped;
    // With 16-bit keys a 1-ulp depth difference can move a Gaussian into the next key step: then
    // Gaussians within one step of each other (relative depth 2^-11) are ties.
    const auto key_step = [&](uint32_t x, uint32_t y) {
      const int64_t d = int64_t{splat::depth_key16(proj[x].depth)} - int64_t{splat::depth_key16(proj[y].depth)};
      return d >= -1 && d <= 1;
    };
    const bool tie = a < proj.size() && b < proj.size() && gt[k] == ct[k] &&
                     (close(proj[a].depth, proj[b].depth, 1e-4, 1e-4) ||
                      (opts.depth_key_bits == 16 && key_step(a, b)));
    if (!tie && order_bad++ < 5)
      std::printf("  list entry %zu: Gaussian %u (gpu) against %u (cpu), not a depth tie\n", k, a, b);
  }
  CHECK(dbg.values.size() == bins.values.size());
  CHECK(order_bad == 0);
  r.swapped = swapped;
  INFO("splat/ranges.comp: per-tile ranges");
  CHECK(test::equal_report(dbg.ranges, bins.ranges, "ranges"));
  INFO("splat/blend.comp: RGBA and expected/median depth per pixel");
  // The CPU blend in the GPU's list order (equal to the CPU's up to the depth ties checked above):
  // swapping two overlapping Gaussians changes the composite by α₁α₂(c₁ − c₂), which no pixel
  // tolerance can hold, while the blend kernel itself must match the CPU's blend of the same list.
  splat::TileBins gpu_order = bins;
  if (swapped != 0 && order_bad == 0) gpu_order.values = dbg.values;
  const splat::SplatImage ci = splat::blend_cpu(proj, gpu_order, cam, opts);

  r.pixels = size_t{gi.width} * gi.height;
  REQUIRE(gi.rgba.size() == ci.rgba.size());
  // RGBA and expected depth: every pixel within 1e-3 (depths relative to the depth scale).
  // Median depth: the depth of the Gaussian that takes T to <= 0.5 is a discontinuous function
  // of the blend, so where lavapipe's exp2 and the CPU's exp differ in the last bits at T = 0.5
  // (opacity-1 Gaussians, degenerate scenes) it may be another Gaussian's depth: those pixels
  // form the boundary band, bounded in size (band_fraction_max) and in value: the GPU's median
  // is still 0 (T stays above 0.5) or the depth of a Gaussian binned to the pixel's tile.
  size_t bad_pixels = 0, bad_band = 0;
  for (size_t p = 0; p < r.pixels; ++p) {
    double dc = 0.0;
    for (int c = 0; c < 4; ++c) dc = std::max(dc, std::fabs(double(gi.rgba[4 * p + c]) - double(ci.rgba[4 * p + c])));
    const double we = double(ci.depth[2 * p]), wm = double(ci.depth[2 * p + 1]);
    const double de = std::fabs(double(gi.depth[2 * p]) - we) / std::max(1.0, std::fabs(we));
    const double dm = std::fabs(double(gi.depth[2 * p + 1]) - wm) / std::max(1.0, std::fabs(wm));
    if (!(dc <= 1e-3) || !(de <= 1e-3)) {
      if (bad_pixels++ < 5)
        std::printf("  pixel %zu: |rgba| %.3g, |expected depth| %.3g over 1e-3\n", p, dc, de);
      continue;
    }
    r.max_interior = std::max({r.max_interior, dc, de});
    if (dm <= 1e-3) {
      r.max_interior = std::max(r.max_interior, dm);
      continue;
    }
    ++r.band;
    r.band_median = std::max(r.band_median, std::isfinite(dm) ? dm : 1e30);
    const double got = double(gi.depth[2 * p + 1]);
    const uint32_t tile = static_cast<uint32_t>((p / gi.width) / SPLAT_TILE * f.grid_x + (p % gi.width) / SPLAT_TILE);
    bool found = got == 0.0;
    for (uint32_t k = bins.ranges[2 * tile]; k < bins.ranges[2 * tile + 1] && !found; ++k)
      found = std::fabs(double(proj[bins.values[k]].depth) - got) <= 1e-4 * std::max(1.0, std::fabs(got));
    if (!found && bad_band++ < 5)
      std::printf("  pixel %zu: median depth %.9g is no depth of a Gaussian binned to its tile\n", p, got);
  }
  INFO("RGBA and expected depth within 1e-3 everywhere");
  CHECK(bad_pixels == 0);
  INFO("median depth: band pixels take another binned Gaussian's depth, and the band is small");
  CHECK(bad_band == 0);
  CHECK(double(r.band) <= band_fraction_max * double(r.pixels));
  return r;
}

inline void report(const std::string& what, const Compare& c) {
  MESSAGE(what << ": " << c.visible << " visible, " << c.instances << " tile instances (" << c.equal_keys
               << " with bit-identical 64-bit keys, " << c.swapped << " swapped depth ties), boundary band " << c.band
               << " of " << c.pixels << " pixels (" << 100.0 * double(c.band) / double(std::max<size_t>(1, c.pixels))
               << " %, median depth only, max rel. error " << c.band_median << "), max interior diff " << c.max_interior);
}


}  // namespace icube::test

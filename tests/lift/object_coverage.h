// The lifted dynamic objects against the frame's instance buffer: the
// objects alone (static set removed) placed at folder frame f and rendered by
// the CPU reference rasterizer; pixels whose instance is a dynamic car
// (>= 10000) covered (alpha > 0.5), and object pixels outside that mask,
// within one pixel of it (the Gaussians' σ blurs outlines by about a pixel at
// test sizes) or beyond. Shared by test_dynamic_lift.cpp and
// test_generate_waymo.cpp.
#pragma once

#include "lift/lift_frames.h"
#include "splat/rasterizer_cpu.h"
#include "splat/splat_scene.h"

#include <string>

namespace icube::test {

struct ObjectCoverage {
  size_t dynamic = 0, covered = 0, fringe = 0, beyond = 0, gaussians = 0;
};

inline ObjectCoverage object_coverage(const splat::SplatScene& sc, const std::string& frames_dir,
                                      const render::FramesMeta& meta, size_t f) {
  splat::SplatScene only = sc;
  only.static_set = splat::GaussianCloud{};
  const splat::GaussianCloud placed = splat::compose_frame(only, lift::splat_frame_of(meta, f));
  ObjectCoverage c;
  c.gaussians = placed.size();
  if (placed.size() == 0) return c;
  splat::SplatOptions so;
  so.pixels = meta.pixels;
  so.depth = false;
  const splat::SplatImage img = splat::render_cpu(placed, lift::frame_camera(meta, f), so);
  const lift::FrameImages im = lift::read_frame_images(frames_dir, meta, f);
  const int W = int(meta.width), H = int(meta.height);
  auto dynamic_at = [&](int x, int y) {
    return x >= 0 && y >= 0 && x < W && y < H &&
           im.instance[size_t(y) * size_t(W) + size_t(x)] >= lift::kDynamicInstanceMin;
  };
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const size_t p = size_t(y) * size_t(W) + size_t(x);
      const bool is_dyn = dynamic_at(x, y), hit = img.rgba[4 * p + 3] > 0.5f;
      c.dynamic += is_dyn;
      c.covered += is_dyn && hit;
      if (!hit || is_dyn) continue;
      bool near = false;
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) near = near || dynamic_at(x + dx, y + dy);
      ++(near ? c.fringe : c.beyond);
    }
  return c;
}

}  // namespace icube::test

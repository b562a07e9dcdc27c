// The GSM's inputs from a frames folder and the world; see gsm_lift_inputs.h.
#include "lift/gsm_lift_inputs.h"

#include "kernels/nn/interpolate.h"
#include "nn/gsm/gsm_rays.h"
#include "scene/input_error.h"

#include <algorithm>
#include <cmath>

namespace icube::lift {

glm::dmat4 GsmGridFrame::grid_to_world() const {
  glm::dmat4 m(1.0);
  m[3] = glm::dvec4(offset, 1.0);
  return m;
}

GsmGridFrame gsm_grid_frame(const world::VoxelGrid& world, const glm::dvec3& anchor_point, const std::string& world_name) {
  if (std::fabs(world.voxel_size() - nn::kGsmVoxelSize) > 1e-9)
    throw scene::InputError(world_name, "", "the GSM takes 0.2 m voxels; this world's are " +
                                                std::to_string(world.voxel_size()) + " m");
  GsmGridFrame g;
  g.anchor = world.world_to_ijk(anchor_point);
  if (!world::ijk_in_range(g.anchor))
    throw scene::InputError(world_name, "", "the first key camera lies outside the world's coordinate range");
  g.offset = world.origin() + glm::dvec3(g.anchor) * world.voxel_size();
  return g;
}

std::vector<nn::Ijk> gsm_crop_voxels(const world::VoxelGrid& world, const GsmGridFrame& g,
                                     const std::vector<glm::dvec3>& cameras, double radius) {
  std::vector<nn::Ijk> out;
  const double r2 = radius * radius;
  world.for_each_voxel([&](const glm::ivec3& ijk, const world::Voxel&) {
    if (radius > 0.0) {
      const glm::dvec3 c = world.ijk_to_world(ijk);
      bool near = false;
      for (const glm::dvec3& cam : cameras) {
        const double dx = c.x - cam.x, dy = c.y - cam.y;
        if (dx * dx + dy * dy <= r2) {
          near = true;
          break;
        }
      }
      if (!near) return;
    }
    out.push_back({ijk.x - g.anchor.x, ijk.y - g.anchor.y, ijk.z - g.anchor.z});
  });
  std::sort(out.begin(), out.end());
  return out;
}

namespace {

// PyTorch's "nearest": source index floor(dst * in / out).
size_t nearest_source(uint32_t dst, uint32_t in, uint32_t out) {
  return std::min<size_t>(size_t(in) - 1, size_t(std::floor(double(dst) * double(in) / double(out))));
}

}  // namespace

GsmFrame gsm_frame(const FrameImages& im, uint32_t in_w, uint32_t in_h, uint32_t out_w, uint32_t out_h) {
  GsmFrame f;
  f.width = out_w;
  f.height = out_h;
  const size_t in_px = size_t(in_w) * in_h, out_px = size_t(out_w) * out_h;
  if (im.rgb.size() != in_px * 3 || im.sky.size() != in_px || im.instance.size() != in_px)
    throw std::invalid_argument("gsm_frame: the images are not " + std::to_string(in_w) + " x " + std::to_string(in_h));
  if (in_w == out_w && in_h == out_h) {
    f.rgb.resize(in_px * 3);
    for (size_t i = 0; i < f.rgb.size(); ++i) f.rgb[i] = float(im.rgb[i]) / 255.0f;
    f.sky = im.sky;
    f.instance = im.instance;
    return f;
  }
  nn::CpuTensor planar({1, 3, int64_t(in_h), int64_t(in_w)});
  for (size_t p = 0; p < in_px; ++p)
    for (size_t c = 0; c < 3; ++c) planar.data[c * in_px + p] = float(im.rgb[3 * p + c]) / 255.0f;
  const nn::CpuTensor resized = nn::cpu::resize_bilinear(planar, int64_t(out_h), int64_t(out_w), false);
  f.rgb.resize(out_px * 3);
  for (size_t p = 0; p < out_px; ++p)
    for (size_t c = 0; c < 3; ++c) f.rgb[3 * p + c] = std::clamp(resized.data[c * out_px + p], 0.0f, 1.0f);
  f.sky.resize(out_px);
  f.instance.resize(out_px);
  for (uint32_t y = 0; y < out_h; ++y) {
    const size_t sy = nearest_source(y, in_h, out_h);
    for (uint32_t x = 0; x < out_w; ++x) {
      const size_t src = sy * in_w + nearest_source(x, in_w, out_w), dst = size_t(y) * out_w + x;
      f.sky[dst] = im.sky[src];
      f.instance[dst] = im.instance[src];
    }
  }
  return f;
}

std::array<float, 6> gsm_intrinsics(const render::PinholeIntrinsics& K, render::PixelConvention pixels, uint32_t out_w,
                                    uint32_t out_h) {
  const double sx = double(out_w) / double(K.width), sy = double(out_h) / double(K.height);
  // Pixel-centre coordinates scale with the image; the model's rays go through integer coordinates.
  const double centre = pixels == render::PixelConvention::Integer ? 0.5 : 0.0;
  return {float(K.fx * sx), float(K.fy * sy), float((K.cx + centre) * sx - 0.5), float((K.cy + centre) * sy - 0.5),
          float(out_w), float(out_h)};
}

std::array<float, 16> gsm_pose(const glm::dmat4& c2w, const GsmGridFrame& g) {
  std::array<float, 16> p{};
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) p[size_t(4 * r + c)] = float(c2w[c][r]);
  for (int r = 0; r < 3; ++r) p[size_t(4 * r + 3)] = float(c2w[3][r] - g.offset[r]);
  return p;
}

}  // namespace icube::lift

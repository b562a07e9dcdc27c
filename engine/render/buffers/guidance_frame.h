// One rendered guidance frame: the per-pixel results of the voxel ray caster
// turned into InfiniCube's buffers (conventions §10.2, §10.4), and the
// encoders of the images written per frame.
//
// Per pixel (row-major, W·H): z-depth = t_depth · d_cam.z (metres, 0 = no
// depth run: miss, or a run that starts at t = 0), semantic class and
// instance of the first voxel with chord >= 1 cm (0 / 0 on a miss), entry
// face normal (0 none, ±(axis + 1), world axes). d_cam.z = 1 / |K^-1 [u+o, v+o, 1]|.
// Depth PNG: uint16 trunc(z · 100) (cm), clamped to 65535 (655.35 m).
// Semantic RGB: kGuidancePalette[palette_index(class)] (sky / miss = entry 8),
// replaced by the instance's PuRd colour where instance > 0.
// Depth visualisation (ours, for viewing only): z mapped through a fixed
// blue-to-yellow ramp over [0, depth_vis_max] metres, no depth = black.
// Normals (optional): (n + 1) / 2 · 255 of the world-axis face normal, none = black.
#pragma once

#include "render/buffers/instance_colors.h"
#include "render/camera.h"
#include "shared/raycast_params.h"

#include <cstdint>
#include <map>
#include <vector>

namespace icube::render {

struct GuidanceFrame {
  uint32_t width = 0, height = 0;
  std::vector<float> zdepth;      // metres
  std::vector<uint8_t> classes;   // semantic class per pixel
  std::vector<uint16_t> instance;
  std::vector<int8_t> normal;     // RaycastHit.normal
  uint64_t rays() const { return uint64_t{width} * height; }
};

GuidanceFrame frame_from_hits(const std::vector<shader::RaycastHit>& hits, const PinholeIntrinsics& K,
                              PixelConvention pixels);

std::vector<uint16_t> depth_centimetres(const std::vector<float>& zdepth);
std::vector<uint8_t> semantic_rgb(const GuidanceFrame& f, const std::map<uint16_t, Rgb8>& instance_colors);
inline constexpr double kDepthVisMaxMetres = 80.0;
std::vector<uint8_t> depth_vis_rgb(const std::vector<float>& zdepth, double max_metres = kDepthVisMaxMetres);
std::vector<uint8_t> normal_rgb(const GuidanceFrame& f);

}  // namespace icube::render

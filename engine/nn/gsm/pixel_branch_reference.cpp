// The GSM's pixel branch on the CPU; see pixel_branch_reference.h.
#include "nn/gsm/pixel_branch_reference.h"

#include "kernels/nn/conv3d.h"
#include "kernels/nn/interpolate.h"
#include "nn/gsm/gsm_json.h"
#include "scene/input_error.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace icube::nn {

namespace {

using cpu::detail::D;

const std::string kParams = "backbone.params.backbone_2d_params.";
const std::string kPrefix = "backbone.backbone_2d.";

void require(bool ok, const std::string& what) {
  if (!ok) throw std::invalid_argument("pixel branch: " + what);
}

// A [V, C, h, w] map at H x W: as is, or bilinearly resized (align_corners false), as reshape_bnhwc_to_target.
CpuTensor at_size(const CpuTensor& x, int64_t H, int64_t W) {
  return x.dim(2) == H && x.dim(3) == W ? x : cpu::resize_bilinear(x, H, W, false);
}

double sigmoid(double v) { return 1.0 / (1.0 + std::exp(-v)); }

// The official create_rays_from_intrinsic_torch_batch for one pixel: the point at camera depth 1 taken
// to the grid (float32 result), minus the camera centre, normalised.
struct Ray {
  float dir[3];
};

Ray pixel_ray(const std::array<float, 16>& P, const std::array<float, 6>& K, int64_t row, int64_t col) {
  const float uu = (static_cast<float>(col) - K[2]) / K[0];
  const float vv = (static_cast<float>(row) - K[3]) / K[1];
  const double local[4] = {uu, vv, 1.0, 1.0};
  float d[3];
  for (int i = 0; i < 3; ++i) {
    double s = 0.0;
    for (int j = 0; j < 4; ++j) s += D(P[static_cast<size_t>(i * 4 + j)]) * local[j];
    d[i] = static_cast<float>(s) - P[static_cast<size_t>(i * 4 + 3)];
  }
  const double norm = std::sqrt(D(d[0]) * D(d[0]) + D(d[1]) * D(d[1]) + D(d[2]) * D(d[2]));
  Ray r;
  for (int i = 0; i < 3; ++i) r.dir[i] = static_cast<float>(D(d[i]) / norm);
  return r;
}

}  // namespace

PixelBranchConfig pixel_branch_config_from_json(const nlohmann::json& j) {
  const std::string src = "the GSM config";
  PixelBranchConfig c;
  c.unet = xunet_config_from_json(gsm_json::at(j, kParams + "unet2d_params", src));
  const std::string base = kParams;
  const std::string source = gsm_json::text(j, base + "feature_source", src);
  if (source != "original_rgb")
    throw std::invalid_argument("pixel branch reference: feature_source \"" + source + "\" is not implemented (only original_rgb)");
  for (const nlohmann::json& p : gsm_json::at(j, base + "concat_depth_priors", src)) {
    const std::string name = p.is_string() ? p.get<std::string>() : std::string();
    if (name == "voxel_depth")
      c.voxel_depth_prior = true;
    else if (name == "masked_voxel_depth")
      c.masked_voxel_depth_prior = true;
    else if (name == "dav2_feature")
      c.dav2_feature_prior = true;
    else
      throw std::invalid_argument("pixel branch reference: depth prior \"" + p.dump() + "\" is not implemented");
  }
  if (c.masked_voxel_depth_prior) c.depth_patch_size = gsm_json::integer(j, base + "masked_voxel_depth_params.patch_size", src);
  c.gs_per_pixel = gsm_json::integer(j, base + "gs_per_pixel", src);
  c.gs_dim = gsm_json::integer(j, base + "gs_dim", src);
  c.znear = gsm_json::number(j, base + "znear", src);
  c.zfar = gsm_json::number(j, base + "zfar", src);
  c.max_scale = gsm_json::number(j, base + "max_scale", src);
  const std::string depth = gsm_json::text(j, base + "interpret_output_depth", src);
  if (depth != "weight" && depth != "inverse_metric_depth")
    throw scene::InputError(src, base + "interpret_output_depth", "must be \"weight\" or \"inverse_metric_depth\"");
  c.inverse_metric_depth = depth == "inverse_metric_depth";
  c.midground_only = gsm_json::has(j, "backbone.params.use_3d") && gsm_json::boolean(j, "backbone.params.use_3d", src);
  if (c.gs_per_pixel < 1 || c.gs_dim < 10) throw scene::InputError(src, base + "gs_dim", "needs gs_per_pixel >= 1 and gs_dim >= 10");
  if (c.depth_patch_size < 1) throw scene::InputError(src, base + "masked_voxel_depth_params.patch_size", "must be positive");
  return c;
}

CpuTensor pixel_branch_unet_input(const PixelBranchConfig& c, const GsmInputs& in, const CpuTensor& voxel_depth,
                                  const CpuTensor& dav2_feature, GsmTrace* trace) {
  const int64_t V = in.batch * in.views, H = in.height, W = in.width;
  CpuTensor x = gsm_images_nchw(in);  // original_rgb [V, 3, H, W]

  if (c.voxel_depth_prior || c.masked_voxel_depth_prior) {
    require(voxel_depth.rank() == 4 && voxel_depth.dim(0) == V && voxel_depth.dim(1) == 1,
            "voxel depth " + voxel_depth.shape_text() + " is not [" + std::to_string(V) + ", 1, h, w]");
    const CpuTensor depth = at_size(voxel_depth, H, W);
    if (c.voxel_depth_prior) x = cpu::concat_channels(x, depth);
    if (c.masked_voxel_depth_prior) {
      // mask_image_patches: each P x P patch kept or zeroed (the patch grid must tile the image).
      const int64_t P = c.depth_patch_size, rows = H / P, cols = W / P;
      require(H % P == 0 && W % P == 0, "the image (" + std::to_string(H) + " x " + std::to_string(W) +
                                            ") is not a whole number of depth patches of " + std::to_string(P));
      require(static_cast<int64_t>(in.depth_patch_keep.size()) == V * rows * cols,
              "depth_patch_keep has " + std::to_string(in.depth_patch_keep.size()) + " entries, not " +
                  std::to_string(V * rows * cols) + " (V x H/P x W/P)");
      CpuTensor masked = depth;
      for (int64_t v = 0; v < V; ++v)
        for (int64_t r = 0; r < H; ++r)
          for (int64_t col = 0; col < W; ++col)
            if (!in.depth_patch_keep[static_cast<size_t>((v * rows + r / P) * cols + col / P)])
              masked.data[static_cast<size_t>((v * H + r) * W + col)] *= 0.0f;
      trace_put(trace, "pix.masked_voxel_depth", masked);
      x = cpu::concat_channels(x, masked);
    }
  }
  if (c.dav2_feature_prior) {
    require(dav2_feature.rank() == 4 && dav2_feature.dim(0) == V,
            "DAV2 feature " + dav2_feature.shape_text() + " is not [" + std::to_string(V) + ", C, h, w]");
    x = cpu::concat_channels(x, at_size(dav2_feature, H, W));
  }
  trace_put(trace, "pix.unet_in", x);
  return x;
}

std::vector<PixelGaussians> decode_pixel_gaussians(const PixelBranchConfig& c, const GsmInputs& in, const CpuTensor& gs_params,
                                                   const std::vector<uint8_t>& grid_fg_mask, GsmTrace* trace) {
  const int64_t B = in.batch, N = in.views, H = in.height, W = in.width, G = c.gs_per_pixel, GD = c.gs_dim;
  require(gs_params.shape == std::vector<int64_t>({B, N, H, W, G * GD}),
          "gs_params " + gs_params.shape_text() + " is not [B, N, H, W, gs_per_pixel * gs_dim]");
  require(static_cast<int64_t>(grid_fg_mask.size()) == B * N * H * W,
          "the grid-foreground mask has " + std::to_string(grid_fg_mask.size()) + " entries, not B x N x H x W");
  for (int64_t v = 0; v < B * N; ++v) {
    const std::array<float, 6>& K = in.intrinsics[static_cast<size_t>(v)];
    if (static_cast<int64_t>(K[4]) != W || static_cast<int64_t>(K[5]) != H)
      throw scene::InputError("intrinsics", "view " + std::to_string(v),
                              "width and height must be the image's " + std::to_string(W) + " x " + std::to_string(H));
  }

  // get_mask: mid-ground = fg - fg * grid_fg (with the voxel branch), else fg; kept where > 0.
  CpuTensor mask({B, N, H, W});
  for (int64_t v = 0; v < B * N; ++v)
    for (int64_t p = 0; p < H * W; ++p) {
      const float fg = static_cast<float>(in.mask(v / N, v % N, p / W, p % W, 0));
      const float grid = static_cast<float>(grid_fg_mask[static_cast<size_t>(v * H * W + p)]);
      mask.data[static_cast<size_t>(v * H * W + p)] = c.midground_only ? fg - fg * grid : fg;
    }
  trace_put(trace, "pix.gaussian_pixel_mask", mask);

  const int64_t colours = GD - 9;
  const float max_scale = static_cast<float>(c.max_scale);
  std::vector<PixelGaussians> out(static_cast<size_t>(B));
  for (int64_t b = 0; b < B; ++b) {
    int64_t n = 0;
    for (int64_t p = 0; p < N * H * W; ++p) n += mask.data[static_cast<size_t>(b * N * H * W + p)] > 0.0f ? G : 0;
    PixelGaussians& g = out[static_cast<size_t>(b)];
    g.means = CpuTensor({n, 3});
    g.scales = CpuTensor({n, 3});
    g.rotations = CpuTensor({n, 4});
    g.opacities = CpuTensor({n, 1});
    g.colors = CpuTensor({n, colours});
    g.src.reserve(static_cast<size_t>(n * 4));
    int64_t k = 0;
    for (int64_t view = 0; view < N; ++view) {
      const int64_t v = b * N + view;
      const std::array<float, 16>& P = in.poses[static_cast<size_t>(v)];
      const std::array<float, 6>& K = in.intrinsics[static_cast<size_t>(v)];
      for (int64_t row = 0; row < H; ++row)
        for (int64_t col = 0; col < W; ++col) {
          if (!(mask.data[static_cast<size_t>((v * H + row) * W + col)] > 0.0f)) continue;
          const Ray ray = pixel_ray(P, K, row, col);
          // <camera z axis (pose column 2), ray>: the cosine to the optical axis.
          const float cosine = P[2] * ray.dir[0] + P[6] * ray.dir[1] + P[10] * ray.dir[2];
          for (int64_t s = 0; s < G; ++s, ++k) {
            const float* raw = gs_params.data.data() + ((v * H + row) * W + col) * G * GD + s * GD;
            const float weight = static_cast<float>(sigmoid(raw[0]));
            const double depth = c.inverse_metric_depth ? 1.0 / D(weight) : D(weight) * (c.zfar - c.znear) + c.znear;
            const double distance = D(static_cast<float>(depth)) / D(cosine);
            for (int i = 0; i < 3; ++i) {
              g.means.data[static_cast<size_t>(k * 3 + i)] = static_cast<float>(D(P[static_cast<size_t>(i * 4 + 3)]) + distance * D(ray.dir[i]));
              g.scales.data[static_cast<size_t>(k * 3 + i)] =
                  std::min(static_cast<float>(std::exp(D(raw[1 + i]) - 2.3)), max_scale);
            }
            double q2 = 0.0;
            for (int i = 0; i < 4; ++i) q2 += D(raw[4 + i]) * D(raw[4 + i]);
            const double qn = std::max(std::sqrt(q2), 1e-12);
            for (int i = 0; i < 4; ++i) g.rotations.data[static_cast<size_t>(k * 4 + i)] = static_cast<float>(D(raw[4 + i]) / qn);
            g.opacities.data[static_cast<size_t>(k)] = static_cast<float>(sigmoid(D(raw[8]) - 1.0));
            for (int64_t i = 0; i < colours; ++i) g.colors.data[static_cast<size_t>(k * colours + i)] = raw[9 + i];
            g.src.insert(g.src.end(), {static_cast<int32_t>(view), static_cast<int32_t>(row), static_cast<int32_t>(col),
                                       static_cast<int32_t>(s)});
          }
        }
    }
  }
  return out;
}

std::vector<PixelGaussians> pixel_branch_forward(const PixelBranchConfig& c, const GsmWeights& w, const GsmInputs& in,
                                                 const CpuTensor& voxel_depth, const std::vector<uint8_t>& grid_fg_mask,
                                                 const CpuTensor& dav2_feature, GsmTrace* trace) {
  const int64_t B = in.batch, N = in.views, H = in.height, W = in.width, V = B * N;
  const CpuTensor unet_in = pixel_branch_unet_input(c, in, voxel_depth, dav2_feature, trace);
  const CpuTensor unet_out = xunet_forward(c.unet, w, kPrefix + "net.", unet_in, trace);
  trace_put(trace, "pix.unet_out", unet_out);
  // linear_out per pixel: [V, C, H, W] -> [V * H * W, C] -> [B, N, H, W, G * D].
  const int64_t C = unet_out.dim(1), out = static_cast<int64_t>(c.gs_per_pixel) * c.gs_dim;
  CpuTensor pixels({V * H * W, C});
  for (int64_t v = 0; v < V; ++v)
    for (int64_t ch = 0; ch < C; ++ch)
      for (int64_t p = 0; p < H * W; ++p)
        pixels.data[static_cast<size_t>((v * H * W + p) * C + ch)] = unet_out.data[static_cast<size_t>((v * C + ch) * H * W + p)];
  CpuTensor params = cpu::linear(pixels, w.at(kPrefix + "linear_out.weight", {out, C}), &w.at(kPrefix + "linear_out.bias", {out}));
  params.shape = {B, N, H, W, out};
  trace_put(trace, "pix.gs_params", params);
  return decode_pixel_gaussians(c, in, params, grid_fg_mask, trace);
}

}  // namespace icube::nn

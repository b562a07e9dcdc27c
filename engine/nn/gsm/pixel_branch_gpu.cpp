// The GSM's pixel branch on the GPU; see pixel_branch_gpu.h.
#include "nn/gsm/pixel_branch_gpu.h"

#include "kernels/nn/batch_norm.h"
#include "kernels/nn/gsm_pixel_gaussians.h"
#include "nn/gsm/xunet_gpu.h"
#include "scene/input_error.h"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace icube::nn {

namespace {

const std::string kPrefix = "backbone.backbone_2d.";

uint32_t u32(int64_t v) { return static_cast<uint32_t>(v); }

void require(bool ok, const std::string& what) {
  if (!ok) throw std::invalid_argument("pixel branch gpu: " + what);
}

void require_shape(const DeviceTensor& t, const std::vector<int64_t>& shape, const std::string& what) {
  require(t.buf && t.shape == shape, what + " " + shape_text(t.shape) + " is not " + shape_text(shape));
}

// Host floats written into a new tensor ([B, C, ...], e.g. [1, n]) in command order (update_buffer, at most 64 KiB a command).
DeviceTensor write_floats(LayerRecorder& L, const std::vector<float>& data, std::vector<int64_t> shape) {
  DeviceTensor t = L.alloc(std::move(shape));
  gpu::CommandList& cmd = L.cmd();
  cmd.barrier(gpu::deps::kComputeToTransfer);  // the pooled buffer may still be read by earlier work
  constexpr size_t kChunk = 65536 / sizeof(float);
  for (size_t i = 0; i < data.size(); i += kChunk) {
    const size_t n = std::min(kChunk, data.size() - i);
    cmd.update_buffer(t.buf->binding(i * 4, n * 4), data.data() + i, n * 4);
  }
  cmd.barrier(gpu::deps::kTransferToCompute);
  return t;
}

// A [V, C, h, w] map at H x W: as is, or bilinearly resized (align_corners false).
DeviceTensor at_size(LayerRecorder& L, const DeviceTensor& x, int64_t H, int64_t W) {
  return x.shape[2] == H && x.shape[3] == W ? x : L.interpolate(x, H, W, kernels::nn::InterpolateMode::bilinear, false);
}

// mask_image_patches: the depth [V, 1, H, W] with the dropped P x P patches zeroed. Viewed as [1, V * H * W / P, P],
// each row of P pixels lies in one patch: a channel affine with scale keep (0 / 1) and shift 0 (x * 1 + 0 = x).
DeviceTensor masked_depth(LayerRecorder& L, const PixelBranchConfig& c, const GsmInputs& in, const DeviceTensor& depth) {
  const int64_t V = in.batch * in.views, H = in.height, W = in.width, P = c.depth_patch_size, rows = H / P, cols = W / P;
  require(H % P == 0 && W % P == 0, "the image (" + std::to_string(H) + " x " + std::to_string(W) +
                                        ") is not a whole number of depth patches of " + std::to_string(P));
  require(static_cast<int64_t>(in.depth_patch_keep.size()) == V * rows * cols,
          "depth_patch_keep has " + std::to_string(in.depth_patch_keep.size()) + " entries, not " + std::to_string(V * rows * cols) +
              " (V x H/P x W/P)");
  const int64_t runs = V * H * cols;
  std::vector<float> keep(static_cast<size_t>(runs));
  for (int64_t v = 0; v < V; ++v)
    for (int64_t y = 0; y < H; ++y)
      for (int64_t col = 0; col < cols; ++col)
        keep[static_cast<size_t>((v * H + y) * cols + col)] =
            in.depth_patch_keep[static_cast<size_t>((v * rows + y / P) * cols + col)] ? 1.0f : 0.0f;
  const DeviceTensor scale = write_floats(L, keep, {1, runs});
  const DeviceTensor shift = write_floats(L, std::vector<float>(static_cast<size_t>(runs), 0.0f), {1, runs});
  DeviceTensor y = L.alloc(depth.shape);
  kernels::nn::BatchNorm op(L.cmd().context());
  op.record(L.cmd(), {1, u32(runs), static_cast<uint64_t>(P)}, *depth.buf, *scale.buf, *shift.buf, *y.buf);
  L.barrier();
  return y;
}

}  // namespace

void check_pixel_branch_gpu(const PixelBranchConfig& c, const std::string& source) { check_xunet_gpu(c.unet, source); }

CpuTensor pixel_branch_foreground(const GsmInputs& in) {
  const int64_t V = in.batch * in.views, HW = in.height * in.width;
  CpuTensor fg({V, 1, in.height, in.width});
  for (int64_t v = 0; v < V; ++v)
    for (int64_t p = 0; p < HW; ++p)
      fg.data[static_cast<size_t>(v * HW + p)] = in.mask(v / in.views, v % in.views, p / in.width, p % in.width, 0) ? 1.0f : 0.0f;
  return fg;
}

PixelBranchGpuOutput pixel_branch_gpu(LayerRecorder& L, const PixelBranchConfig& c, const GsmInputs& in,
                                      const PixelBranchGpuInputs& x, PixelBranchGpuTrace* trace) {
  const int64_t V = in.batch * in.views, H = in.height, W = in.width, G = c.gs_per_pixel, D = c.gs_dim;
  auto put = [&](const std::string& name, const DeviceTensor& t) {
    if (trace) trace->tensors[name] = t;
  };
  require_shape(x.images, {V, 3, H, W}, "the images");
  require_shape(x.grid_foreground, {V, 1, H, W}, "the grid-foreground mask");
  require_shape(x.foreground, {V, 1, H, W}, "the segmentation foreground");
  require(static_cast<int64_t>(in.poses.size()) == V && static_cast<int64_t>(in.intrinsics.size()) == V,
          "the inputs hold " + std::to_string(in.poses.size()) + " poses and " + std::to_string(in.intrinsics.size()) +
              " intrinsics for " + std::to_string(V) + " views");
  for (int64_t v = 0; v < V; ++v) {
    const std::array<float, 6>& K = in.intrinsics[static_cast<size_t>(v)];
    if (static_cast<int64_t>(K[4]) != W || static_cast<int64_t>(K[5]) != H)
      throw scene::InputError("intrinsics", "view " + std::to_string(v),
                              "width and height must be the image's " + std::to_string(W) + " x " + std::to_string(H));
  }

  // The UNet input: RGB, the depth priors in the official order, the DAV2 feature.
  DeviceTensor unet_in = x.images;
  if (c.voxel_depth_prior || c.masked_voxel_depth_prior) {
    require(x.voxel_depth.buf && x.voxel_depth.shape.size() == 4 && x.voxel_depth.batch() == V && x.voxel_depth.channels() == 1,
            "the voxel depth " + shape_text(x.voxel_depth.shape) + " is not [" + std::to_string(V) + ", 1, h, w]");
    const DeviceTensor depth = at_size(L, x.voxel_depth, H, W);
    if (c.voxel_depth_prior) unet_in = L.concat(unet_in, depth);
    if (c.masked_voxel_depth_prior) {
      const DeviceTensor masked = masked_depth(L, c, in, depth);
      put("pix.masked_voxel_depth", masked);
      unet_in = L.concat(unet_in, masked);
    }
  }
  if (c.dav2_feature_prior) {
    require(x.dav2_feature.buf && x.dav2_feature.shape.size() == 4 && x.dav2_feature.batch() == V,
            "the DAV2 feature " + shape_text(x.dav2_feature.shape) + " is not [" + std::to_string(V) + ", C, h, w]");
    unet_in = L.concat(unet_in, at_size(L, x.dav2_feature, H, W));
  }
  put("pix.unet_in", unet_in);

  const DeviceTensor unet_out = xunet_gpu(L, c.unet, kPrefix + "net.", unet_in, trace ? &trace->tensors : nullptr);
  put("pix.unet_out", unet_out);

  // linear_out per pixel: a 1x1 convolution over the tokens -> [V, G * D, H * W].
  const std::vector<int64_t>& ws = L.params().shape(kPrefix + "linear_out.weight");
  require(ws == std::vector<int64_t>({G * D, unet_out.channels()}),
          "linear_out.weight " + shape_text(ws) + " is not [gs_per_pixel * gs_dim, " + std::to_string(unet_out.channels()) + "]");
  const DeviceTensor gs_params = L.conv(LayerRecorder::tokens(unet_out), kPrefix + "linear_out");
  put("pix.gs_params", gs_params);

  // Every pixel's Gaussians and keep value.
  kernels::nn::GsmPixelGaussiansShape s;
  s.views = u32(V);
  s.height = u32(H);
  s.width = u32(W);
  s.gs_per_pixel = u32(G);
  s.gs_dim = u32(D);
  s.znear = static_cast<float>(c.znear);
  s.zfar = static_cast<float>(c.zfar);
  s.max_scale = static_cast<float>(c.max_scale);
  s.inverse_metric_depth = c.inverse_metric_depth;
  s.midground_only = c.midground_only;
  const DeviceTensor cameras = write_floats(L, kernels::nn::pack_gsm_pixel_cameras(in.poses, in.intrinsics),
                                            {1, V * static_cast<int64_t>(kernels::nn::gsm_pixel_camera_floats())});
  PixelBranchGpuOutput out{L.alloc({V, H * W * G, D + 2}), L.alloc({V, 1, H, W})};
  kernels::nn::GsmPixelGaussians op(L.cmd().context());
  op.record(L.cmd(), s, *gs_params.buf, *x.foreground.buf, *x.grid_foreground.buf, *cameras.buf, *out.gaussians.buf, *out.mask.buf);
  L.barrier();
  put("pix.gaussian_pixel_mask", out.mask);
  return out;
}

std::vector<PixelGaussians> compact_pixel_gaussians(const PixelBranchConfig& c, int64_t B, int64_t N, int64_t H, int64_t W,
                                                    const std::vector<float>& gaussians, const std::vector<float>& mask) {
  const int64_t G = c.gs_per_pixel, D = c.gs_dim, R = D + 2, colours = D - 9, px = H * W;
  require(static_cast<int64_t>(mask.size()) == B * N * px && static_cast<int64_t>(gaussians.size()) == B * N * px * G * R,
          "the dense Gaussians (" + std::to_string(gaussians.size()) + " floats) or the mask (" + std::to_string(mask.size()) +
              ") do not fit " + std::to_string(B * N) + " views of " + std::to_string(H) + " x " + std::to_string(W));
  std::vector<PixelGaussians> out(static_cast<size_t>(B));
  for (int64_t b = 0; b < B; ++b) {
    const float* m = mask.data() + b * N * px;
    const int64_t n = G * std::count_if(m, m + N * px, [](float v) { return v > 0.0f; });
    PixelGaussians& g = out[static_cast<size_t>(b)];
    g.means = CpuTensor({n, 3});
    g.scales = CpuTensor({n, 3});
    g.rotations = CpuTensor({n, 4});
    g.opacities = CpuTensor({n, 1});
    g.colors = CpuTensor({n, colours});
    g.src.reserve(static_cast<size_t>(n * 4));
    int64_t k = 0;
    for (int64_t view = 0; view < N; ++view)
      for (int64_t p = 0; p < px; ++p) {
        if (!(m[view * px + p] > 0.0f)) continue;
        for (int64_t s = 0; s < G; ++s, ++k) {
          const float* r = gaussians.data() + (((b * N + view) * px + p) * G + s) * R;
          std::copy(r, r + 3, g.means.data.begin() + k * 3);
          std::copy(r + 3, r + 6, g.scales.data.begin() + k * 3);
          std::copy(r + 6, r + 10, g.rotations.data.begin() + k * 4);
          g.opacities.data[static_cast<size_t>(k)] = r[10];
          std::copy(r + 11, r + R, g.colors.data.begin() + k * colours);
          g.src.insert(g.src.end(), {static_cast<int32_t>(view), static_cast<int32_t>(p / W), static_cast<int32_t>(p % W),
                                     static_cast<int32_t>(s)});
        }
      }
  }
  return out;
}

std::vector<PixelGaussians> download_pixel_gaussians(gpu::Context& ctx, const PixelBranchConfig& c, const GsmInputs& in,
                                                     const PixelBranchGpuOutput& out) {
  return compact_pixel_gaussians(c, in.batch, in.views, in.height, in.width,
                                 gpu::download_vector<float>(ctx, *out.gaussians.buf, out.gaussians.numel()),
                                 gpu::download_vector<float>(ctx, *out.mask.buf, out.mask.numel()));
}

GsmTrace download_pixel_branch_trace(gpu::Context& ctx, const GsmInputs& in, const PixelBranchGpuTrace& trace) {
  const int64_t B = in.batch, N = in.views, H = in.height, W = in.width;
  GsmTrace out;
  for (const auto& [name, t] : trace.tensors) {
    CpuTensor x(t.shape, gpu::download_vector<float>(ctx, *t.buf, t.numel()));
    if (name.rfind("pix.unet.", 0) == 0) {
      x.shape = {t.shape[0], t.shape[1], 1, t.shape[2], t.shape[3]};
    } else if (name == "pix.gs_params") {
      // [V, G * D, H * W] -> [B, N, H, W, G * D].
      const int64_t C = t.channels(), px = t.spatial();
      CpuTensor y({B, N, H, W, C});
      for (int64_t v = 0; v < B * N; ++v)
        for (int64_t ch = 0; ch < C; ++ch)
          for (int64_t p = 0; p < px; ++p)
            y.data[static_cast<size_t>((v * px + p) * C + ch)] = x.data[static_cast<size_t>((v * C + ch) * px + p)];
      x = std::move(y);
    } else if (name == "pix.gaussian_pixel_mask") {
      x.shape = {B, N, H, W};
    }
    out.tensors[name] = std::move(x);
  }
  return out;
}

}  // namespace icube::nn

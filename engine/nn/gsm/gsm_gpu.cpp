// The whole GSM on the GPU; see gsm_gpu.h.
#include "nn/gsm/gsm_gpu.h"

#include "gpu/context.h"
#include "nn/gsm/conv_encoder_gpu.h"
#include "nn/gsm/gsm_rays.h"
#include "nn/gsm/gsm_rays_gpu.h"
#include "nn/gsm/sky_reference.h"
#include "nn/gsm/sky_token_gpu.h"
#include "nn/gsm/pixel_branch_gpu.h"
#include "nn/gsm/voxel_branch_gpu.h"
#include "nn/layer_recorder.h"

#include <algorithm>
#include <chrono>

namespace icube::nn {

namespace {

using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

DeviceTensor upload(gpu::Context& ctx, const CpuTensor& t, const char* name) {
  return {std::make_shared<gpu::Buffer>(gpu::upload_vector(ctx, t.data, name)), t.shape};
}

CpuTensor download(gpu::Context& ctx, const DeviceTensor& t) {
  return CpuTensor(t.shape, gpu::download_vector<float>(ctx, *t.buf, t.numel()));
}

// Views [first, first + count) of a [V, ...] tensor, copied into a pooled tensor (a transfer inside the list).
DeviceTensor view_range(LayerRecorder& L, const DeviceTensor& x, int64_t first, int64_t count) {
  if (first == 0 && count == x.batch()) return x;
  std::vector<int64_t> shape = x.shape;
  shape[0] = count;
  DeviceTensor y = L.alloc(shape);
  const uint64_t per = x.numel() / static_cast<uint64_t>(x.batch()) * 4;
  gpu::CommandList& c = L.cmd();
  c.barrier(gpu::deps::kComputeToTransfer);
  c.copy_buffer(x.buf->binding(static_cast<uint64_t>(first) * per, static_cast<uint64_t>(count) * per), y.buf->binding(0, static_cast<uint64_t>(count) * per));
  c.barrier(gpu::deps::kTransferToCompute);
  return y;
}

void merge(GsmTrace* into, GsmTrace&& from) {
  if (!into) return;
  for (auto& [name, t] : from.tensors) into->tensors[name] = std::move(t);
}

}  // namespace

GsmGpu::GsmGpu(gpu::Context& ctx, const GsmConfig& c, const GsmWeights& w) : ctx_(ctx), config_(c), weights_(w) {
  check_conv_encoder_gpu(c.conv, c.source);
  check_dav2_gpu(c.dav2, c.source);
  check_pixel_branch_gpu(c.pixel, c.source);
  const GsmGpuWeights g = gsm_gpu_weights(w);
  ParameterStoreOptions o;
  o.network = "the GSM";
  o.source = w.source;
  o.host_only = g.host_only;
  store_ = std::make_unique<ParameterStore>(ctx, g.specs, g.tensors, o);
  const std::string m = "skybox.modulator.";
  sky_mlp_ = std::make_unique<gpu::Buffer>(gpu::upload_vector(
      ctx, kernels::nn::pack_gsm_sky_mlp(w.at(m + "pos_emb.weight").data, w.at(m + "pos_emb.bias").data,
                                         w.at(m + "output.weight").data, w.at(m + "output.bias").data),
      "gsm-sky-mlp"));
  sky_colors_ = std::make_unique<kernels::nn::GsmSkyColors>(ctx);
}

GsmGpu::~GsmGpu() = default;

void GsmGpu::finish_stage(std::string label, double ms, bool on_device) {
  stages_.push_back({std::move(label), ms, on_device});
  if (progress_) progress_(stages_.back(), stages_.size(), kStages);
}

GsmOutputs GsmGpu::forward(const GsmInputs& in, GsmTrace* trace) {
  stages_.clear();
  const int64_t B = in.batch, N = in.views, H = in.height, W = in.width;
  GsmOutputs out;
  out.elements.resize(static_cast<size_t>(B));
  LayerRecorder L(ctx_, *store_, "gsm");
  const CpuTensor images_host = gsm_images_nchw(in);
  const CpuTensor effective = gsm_effective_mask(in);
  trace_put(trace, "enc.effective_mask", effective);

  // 1. Image features: the conv encoder and Depth-Anything-V2, one command list.
  Clock::time_point t0 = Clock::now();
  const DeviceTensor images = upload(ctx_, images_host, "gsm-images");
  DeviceTensor conv, dav2;
  std::vector<DeviceTensor> conv_stages;
  Dav2GpuTrace dav2_trace;
  ctx_.submit_and_wait([&](gpu::CommandList& cmd) {
    L.begin(cmd);
    conv = conv_encoder_gpu(L, config_.conv, images, trace ? &conv_stages : nullptr);
    dav2 = dav2_gpu(L, config_.dav2, images, trace ? &dav2_trace : nullptr, &positions_);
    L.end();
  });
  finish_stage("image features (conv encoder, Depth-Anything-V2)", ms_since(t0), true);
  if (trace) {
    for (size_t i = 0; i < conv_stages.size(); ++i)
      trace_put(trace, "enc.conv.project_head." + std::to_string(i), download(ctx_, conv_stages[i]));
    CpuTensor c = download(ctx_, conv);
    c.shape.insert(c.shape.begin(), B);
    c.shape[1] = N;
    trace_put(trace, "enc.conv.out", c);
    merge(trace, download_dav2_trace(ctx_, dav2_trace, B));
  }

  // 2. The sky token (patch embedding and encoder on the device, the used patches' gather on the host).
  t0 = Clock::now();
  out.sky_tokens = sky_tokens_gpu(L, config_.sky, weights_, in, images, trace);
  finish_stage("sky token", ms_since(t0), true);

  // 3. Pixel rays on the voxel ray caster (rays near a tie re-marched in double on the host).
  t0 = Clock::now();
  std::vector<GsmPixelRays> rays;
  GsmRayCastStats ray_stats;
  for (int64_t b = 0; b < B; ++b) rays.push_back(cast_gsm_pixel_rays_gpu(ctx_, in, b, &ray_stats));
  trace_gsm_pixel_rays(rays, trace);
  CpuTensor voxel_depth({B * N, 1, H, W}), grid_fg({B * N, 1, H, W});
  for (int64_t b = 0; b < B; ++b) {
    const GsmPixelRays& r = rays[static_cast<size_t>(b)];
    std::copy(r.voxel_depth.begin(), r.voxel_depth.end(), voxel_depth.data.begin() + b * N * H * W);
    for (size_t i = 0; i < r.grid_foreground.size(); ++i)
      grid_fg.data[static_cast<size_t>(b * N * H * W) + i] = r.grid_foreground[i] ? 1.0f : 0.0f;
  }
  finish_stage("pixel rays (ray caster)", ms_since(t0), true);

  // 4. The voxel branch, one batch element per command list.
  t0 = Clock::now();
  for (int64_t b = 0; b < B; ++b) {
    VoxelBranchGpu branch(ctx_, L);
    VoxelBranchGpuTrace vtrace;
    VoxelBranchGpuOutputs vo;
    const CpuTensor eff(std::vector<int64_t>{N, H, W},
                        std::vector<float>(effective.data.begin() + b * N * H * W, effective.data.begin() + (b + 1) * N * H * W));
    const std::vector<std::array<float, 16>> poses(in.poses.begin() + b * N, in.poses.begin() + (b + 1) * N);
    const std::vector<std::array<float, 6>> intr(in.intrinsics.begin() + b * N, in.intrinsics.begin() + (b + 1) * N);
    ctx_.submit_and_wait([&](gpu::CommandList& cmd) {
      L.begin(cmd);
      const DeviceTensor features = view_range(L, conv, b * N, N);
      vo = voxel_branch_gpu(branch, config_.voxel_unet, config_.voxel_heads, gsm_input_grid(in, b), features,
                            rays[static_cast<size_t>(b)].first_voxel, eff, poses, intr, static_cast<int>(b), trace ? &vtrace : nullptr);
      L.end();
    });
    out.elements[static_cast<size_t>(b)].voxel = vo.gaussians.download(ctx_);
    if (trace) merge(trace, vtrace.download(ctx_));
    branch.release();
  }
  finish_stage("voxel branch", ms_since(t0), true);

  // 5. The pixel branch.
  t0 = Clock::now();
  PixelBranchGpuInputs px;
  px.images = images;
  px.voxel_depth = upload(ctx_, voxel_depth, "gsm-voxel-depth");
  px.grid_foreground = upload(ctx_, grid_fg, "gsm-grid-fg");
  px.foreground = upload(ctx_, pixel_branch_foreground(in), "gsm-foreground");
  px.dav2_feature = dav2;
  PixelBranchGpuOutput po;
  PixelBranchGpuTrace ptrace;
  ctx_.submit_and_wait([&](gpu::CommandList& cmd) {
    L.begin(cmd);
    po = pixel_branch_gpu(L, config_.pixel, in, px, trace ? &ptrace : nullptr);
    L.end();
  });
  std::vector<PixelGaussians> pixel = download_pixel_gaussians(ctx_, config_.pixel, in, po);
  for (int64_t b = 0; b < B; ++b) out.elements[static_cast<size_t>(b)].pixel = std::move(pixel[static_cast<size_t>(b)]);
  if (trace) merge(trace, download_pixel_branch_trace(ctx_, in, ptrace));
  finish_stage("pixel branch", ms_since(t0), true);

  // 6. The sky's colours: the modulator MLP per pixel direction and per panorama direction (the adaLN vectors
  // of each element's token on the host: two small linears).
  t0 = Clock::now();
  {
    const SkyConfig& sc = config_.sky;
    const int64_t C = sc.out_channels, rows = config_.sky_panorama_rows, cols = 2 * rows;
    std::vector<float> modulation;
    for (int64_t b = 0; b < B; ++b) {
      const std::vector<float> m = sky_modulation(sc, weights_, out.sky_tokens.data.data() + b * sc.embed_dim);
      modulation.insert(modulation.end(), m.begin(), m.end());
    }
    const gpu::Buffer mod = gpu::upload_vector(ctx_, modulation, "gsm-sky-modulation");
    const gpu::Buffer image_dirs = gpu::upload_vector(ctx_, sky_image_directions(in).data, "gsm-sky-image-dirs");
    // The panorama's directions once per element (each under its own token).
    const CpuTensor pano = sky_panorama_directions(rows);
    std::vector<float> pano_all;
    for (int64_t b = 0; b < B; ++b) pano_all.insert(pano_all.end(), pano.data.begin(), pano.data.end());
    const gpu::Buffer pano_dirs = gpu::upload_vector(ctx_, pano_all, "gsm-sky-panorama-dirs");
    const uint64_t image_rows = static_cast<uint64_t>(B * N * H * W), pano_rows = static_cast<uint64_t>(rows * cols);
    gpu::Buffer image_rgb(ctx_, std::max<uint64_t>(1, image_rows * static_cast<uint64_t>(C)) * 4, gpu::MemoryUsage::DeviceLocal,
                          "gsm-sky-image");
    gpu::Buffer pano_rgb(ctx_, std::max<uint64_t>(1, static_cast<uint64_t>(B) * pano_rows * static_cast<uint64_t>(C)) * 4,
                         gpu::MemoryUsage::DeviceLocal, "gsm-sky-panorama");
    ctx_.submit_and_wait([&](gpu::CommandList& cmd) {
      kernels::nn::GsmSkyColorsShape s;
      s.hidden = static_cast<uint32_t>(sc.hidden_channels);
      s.out_channels = static_cast<uint32_t>(C);
      s.elements = static_cast<uint32_t>(B);
      s.rows = static_cast<uint32_t>(image_rows);
      s.element_rows = static_cast<uint32_t>(std::max<int64_t>(1, N * H * W));
      sky_colors_->record(cmd, s, image_dirs, *sky_mlp_, mod, image_rgb);
      s.rows = static_cast<uint32_t>(static_cast<uint64_t>(B) * pano_rows);
      s.element_rows = static_cast<uint32_t>(std::max<uint64_t>(1, pano_rows));
      sky_colors_->record(cmd, s, pano_dirs, *sky_mlp_, mod, pano_rgb);
    });
    out.sky_image = CpuTensor({B, N, H, W, C}, gpu::download_vector<float>(ctx_, image_rgb, static_cast<size_t>(image_rows * C)));
    out.sky_panorama = CpuTensor({B, rows, cols, C},
                                 gpu::download_vector<float>(ctx_, pano_rgb, static_cast<size_t>(B * pano_rows * C)));
  }
  finish_stage("sky colours", ms_since(t0), true);
  activation_bytes_ = L.pool().bytes();
  return out;
}

}  // namespace icube::nn

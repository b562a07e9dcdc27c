// The GSM voxel branch on the GPU (engine/nn/gsm/voxel_branch_gpu.h,
// voxel_unet_gpu.h, voxel_heads_gpu.h) against the official gsm_small case
// (../shared/data/models/gsm_small): the lifter and the sparse U-Net fed the
// reference conv features, first voxels and effective mask (and the U-Net alone
// fed the reference lifter output), every vox.* intermediate; the heads and the
// Gaussian decoding fed the reference U-Net output and front masks, vox.occ/
// nonocc.* and gs.b0.voxel.*: features within 1e-4 of their std, integers
// exact. Then a two-view case (the case's camera plus one yawed by 4 degrees
// with the image and features mirrored; first voxels from the CPU ray march)
// through the whole GPU branch against the CPU reference. Runs under the
// validation layer; prints the lavapipe times.
#include <doctest/doctest.h>

#include "gsm_case.h"
#include "nn/gsm/gsm_gpu_weights.h"
#include "nn/gsm/gsm_inputs.h"
#include "nn/gsm/gsm_rays.h"
#include "nn/gsm/voxel_heads_gpu.h"
#include "nn/gsm/voxel_unet_gpu.h"
#include "nn/parameter_store.h"
#include "scene/atomic_file.h"

#include <nlohmann/json.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>
#include <tuple>
#include <vector>

using namespace icube;

namespace {

struct VoxelGpuCase {
  std::string dir;
  nlohmann::json hparams;
  nn::GsmInputs inputs;
  nn::GsmWeights weights;
  nn::VoxelUnetConfig unet;
  nn::VoxelHeadsConfig heads;
  std::unique_ptr<nn::ParameterStore> store;

  explicit VoxelGpuCase(const std::string& d)
      : dir(d),
        hparams(nlohmann::json::parse(scene::read_file(d + "config.json")).at("hparams")),
        inputs(nn::read_gsm_inputs(d + "inputs")),
        weights(nn::load_gsm_weights(d + "weights.safetensors")),
        unet(nn::voxel_unet_config_from_json(hparams)),
        heads(nn::voxel_heads_config_from_json(hparams)) {
    const nn::GsmGpuWeights g = nn::gsm_gpu_weights(weights);
    store = std::make_unique<nn::ParameterStore>(test::gpu_context(), g.specs, g.tensors,
                                                 nn::ParameterStoreOptions{.network = "the GSM", .source = d + "weights.safetensors", .host_only = g.host_only});
  }
};

// A host tensor on the device under `shape` (the same values).
nn::DeviceTensor upload(const nn::CpuTensor& t, std::vector<int64_t> shape, const std::string& name) {
  return {std::make_shared<gpu::Buffer>(gpu::upload_vector(test::gpu_context(), t.data, name)), std::move(shape)};
}

// [rows, C] -> the device's channel-major [1, C, rows].
nn::DeviceTensor upload_rows(const nn::CpuTensor& t, const std::string& name) {
  const int64_t R = t.dim(0), C = t.dim(1);
  nn::CpuTensor cm({C, R});
  for (int64_t r = 0; r < R; ++r)
    for (int64_t c = 0; c < C; ++c) cm.data[static_cast<size_t>(c * R + r)] = t.data[static_cast<size_t>(r * C + c)];
  return upload(cm, {1, C, R}, name);
}

std::vector<int32_t> as_rows(const nn::CpuTensor& t) {
  std::vector<int32_t> v(t.data.size());
  for (size_t i = 0; i < v.size(); ++i) v[i] = static_cast<int32_t>(t.data[i]);
  return v;
}

std::vector<uint8_t> as_bytes(const nn::CpuTensor& t) {
  std::vector<uint8_t> out;
  for (float v : t.data) out.push_back(v != 0.0f ? 1 : 0);
  return out;
}

nn::CpuTensor int_tensor(const std::vector<int32_t>& v, std::vector<int64_t> shape) {
  return nn::CpuTensor(std::move(shape), std::vector<float>(v.begin(), v.end()));
}

nn::CpuTensor drop_batch_axis(nn::CpuTensor t) {
  t.shape.erase(t.shape.begin());
  return t;
}

const nn::CpuTensor& traced(const nn::GsmTrace& t, const std::string& name) {
  REQUIRE_MESSAGE(t.tensors.count(name), "not traced: " << name);
  return t.tensors.at(name);
}

// Records `fn` into one command list through L, runs it, returns the wall time in ms.
template <class F>
double run_recorded(nn::LayerRecorder& L, F&& fn) {
  const auto t0 = std::chrono::steady_clock::now();
  test::gpu_context().submit_and_wait([&](gpu::CommandList& cmd) {
    L.begin(cmd);
    fn();
    L.end();
  });
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

void check_gaussians(const test::GsmTensors& out, const std::string& prefix, const nn::VoxelGaussians& g) {
  const int64_t n = g.count();
  test::check_gsm_tensor(out, prefix + "means", g.means);
  test::check_gsm_tensor(out, prefix + "scales", g.scales);
  test::check_gsm_tensor(out, prefix + "rotations", g.rotations);
  test::check_gsm_tensor(out, prefix + "opacities", g.opacities);
  test::check_gsm_tensor(out, prefix + "colors", g.colors);
  test::check_gsm_tensor(out, prefix + "src_ijk", int_tensor(g.src_ijk, {n, 3}));
  test::check_gsm_tensor(out, prefix + "src_level", int_tensor(g.src_level, {n}));
  test::check_gsm_tensor(out, prefix + "src_sub", int_tensor(g.src_sub, {n}));
}

// The case's view plus a second: the camera yawed by 4 degrees about the grid's z axis, the image, masks and
// conv features mirrored left-right.
struct TwoViews {
  nn::GsmInputs inputs;
  nn::CpuTensor features;  // [2, C, H, W]
};

TwoViews with_second_view(const nn::GsmInputs& one, const nn::CpuTensor& features_one) {
  const int64_t H = one.height, W = one.width, C = features_one.dim(1);
  TwoViews t;
  t.inputs = one;
  std::vector<float> img = one.images.data;
  std::vector<uint8_t> masks = one.masks;
  for (int64_t r = 0; r < H; ++r)
    for (int64_t c = 0; c < W; ++c) {
      for (int64_t k = 0; k < 3; ++k) img.push_back(one.images.data[static_cast<size_t>((r * W + (W - 1 - c)) * 3 + k)]);
      for (int64_t k = 0; k < 4; ++k) masks.push_back(one.masks[static_cast<size_t>((r * W + (W - 1 - c)) * 4 + k)]);
    }
  std::array<float, 16> pose = one.poses[0];
  const double a = 4.0 * 3.14159265358979 / 180.0, ca = std::cos(a), sa = std::sin(a);
  for (size_t col = 0; col < 3; ++col) {  // R2 = Rz(a) R
    const double x = pose[col], y = pose[4 + col];
    pose[col] = static_cast<float>(ca * x - sa * y);
    pose[4 + col] = static_cast<float>(sa * x + ca * y);
  }
  t.inputs.views = 2;
  t.inputs.images = nn::CpuTensor({1, 2, H, W, 3}, img);
  t.inputs.masks = masks;
  t.inputs.poses.push_back(pose);
  t.inputs.intrinsics.push_back(one.intrinsics[0]);
  t.inputs.depth_patch_keep.insert(t.inputs.depth_patch_keep.end(), one.depth_patch_keep.begin(), one.depth_patch_keep.end());
  t.features = nn::CpuTensor({2, C, H, W});
  std::copy(features_one.data.begin(), features_one.data.end(), t.features.data.begin());
  for (int64_t c = 0; c < C; ++c)
    for (int64_t r = 0; r < H; ++r)
      for (int64_t x = 0; x < W; ++x)
        t.features.data[static_cast<size_t>(((C + c) * H + r) * W + x)] = features_one.data[static_cast<size_t>((c * H + r) * W + (W - 1 - x))];
  return t;
}

}  // namespace

TEST_CASE("gsm gpu: the voxel branch's lifter and sparse U-Net match vox.*") {
  const std::string dir = test::gsm_small_dir();
  if (dir.empty()) return;
  gpu::Context& ctx = test::gpu_context();
  VoxelGpuCase g(dir);
  const test::GsmTensors ref(dir + "intermediates.safetensors");
  REQUIRE(g.inputs.batch == 1);
  const nn::CpuTensor features = drop_batch_axis(ref.get("enc.conv.out"));  // [N, C, H, W]
  const std::vector<int32_t> first = as_rows(ref.get("vox.lifter.pixel_first_voxel.b0"));
  const nn::CpuTensor effective = drop_batch_axis(nn::gsm_effective_mask(g.inputs));
  const nn::SparseGrid grid = nn::gsm_input_grid(g.inputs, 0);
  const nn::DeviceTensor x = upload(features, features.shape, "gsm-conv-features");
  const nn::DeviceTensor ref_lifted = upload_rows(ref.get("vox.lifter"), "gsm-ref-lifted");

  nn::LayerRecorder L(ctx, *g.store, "gsm-voxel-test");
  nn::VoxelBranchGpu B(ctx, L);
  nn::VoxelBranchGpuTrace whole, unet_alone;
  const double ms_whole = run_recorded(L, [&] {
    const nn::VoxelGridGpu input = B.grid(grid);
    const nn::DeviceTensor lifted = nn::voxel_lifter_gpu(B, g.unet, x, first, effective, grid.size(), 0, &whole);
    nn::voxel_unet_gpu(B, g.unet, input, lifted, 0, &whole);
  });
  const double ms_unet = run_recorded(L, [&] { nn::voxel_unet_gpu(B, g.unet, B.grid(grid), ref_lifted, 0, &unet_alone); });
  MESSAGE("lavapipe: lifter + U-Net " << ms_whole << " ms, U-Net alone " << ms_unet << " ms (" << grid.size() << " voxels)");

  const nn::GsmTrace t_whole = whole.download(ctx), t_unet = unet_alone.download(ctx);
  B.release();
  test::check_gsm_tensor(ref, "vox.lifter.in", traced(t_whole, "vox.lifter.in"));
  test::check_gsm_tensor(ref, "vox.lifter", traced(t_whole, "vox.lifter"));
  test::check_gsm_tensor(ref, "vox.pre_conv", traced(t_unet, "vox.pre_conv"));
  for (const std::string name : {"vox.encoders.Enc0.0", "vox.encoders.Enc1.0", "vox.encoders.Enc2.0",
                                 "vox.pre_kl_bottleneck.pre_kl_bottleneck_0.0", "vox.post_kl_bottleneck.post_kl_bottleneck_0.0",
                                 "vox.post_kl_bottleneck.post_kl_bottleneck_1.0", "vox.decoders.Dec-2.0", "vox.decoders.Dec-3.0",
                                 "vox.out.b0"}) {
    test::check_gsm_tensor(ref, name + ".ijk", traced(t_unet, name + ".ijk"));
    test::check_gsm_tensor(ref, name, traced(t_unet, name));
  }
  // The whole chain (the GPU lifter's output into the U-Net).
  test::check_gsm_tensor(ref, "vox.out.b0", traced(t_whole, "vox.out.b0"));
}

TEST_CASE("gsm gpu: the voxel heads and Gaussian decoding match vox.occ/nonocc and gs.b0.voxel.*") {
  const std::string dir = test::gsm_small_dir();
  if (dir.empty()) return;
  gpu::Context& ctx = test::gpu_context();
  VoxelGpuCase g(dir);
  const test::GsmTensors ref(dir + "intermediates.safetensors"), out(dir + "outputs.safetensors");
  const nn::CpuTensor features = drop_batch_axis(ref.get("enc.conv.out"));

  nn::VoxelHeadsGpuInputs in;
  in.grid = nn::gsm_input_grid(g.inputs, 0);
  in.voxel_features = upload_rows(ref.get("vox.out.b0"), "gsm-ref-voxel-features");
  in.front.front = as_bytes(ref.get("vox.occ_front_mask.b0"));
  in.front.front_per_view = as_bytes(ref.get("vox.occ_front_per_camera.b0"));
  in.image_features = upload(features, features.shape, "gsm-conv-features");
  in.effective_mask = drop_batch_axis(ref.get("enc.effective_mask"));
  in.poses.assign(g.inputs.poses.begin(), g.inputs.poses.begin() + g.inputs.views);
  in.intrinsics.assign(g.inputs.intrinsics.begin(), g.inputs.intrinsics.begin() + g.inputs.views);

  nn::LayerRecorder L(ctx, *g.store, "gsm-voxel-test");
  nn::VoxelBranchGpu B(ctx, L);
  nn::VoxelBranchGpuTrace trace;
  nn::VoxelGaussiansGpu gaussians;
  const double ms = run_recorded(L, [&] { gaussians = nn::voxel_heads_gpu(B, g.heads, in, 0, &trace); });
  MESSAGE("lavapipe: voxel heads and decoding " << ms << " ms (" << gaussians.count() << " Gaussians)");
  const nn::GsmTrace t = trace.download(ctx);
  for (const char* name : {"vox.occ.b0.ijk", "vox.occ.b0.head_in", "vox.occ.b0.head_out", "vox.nonocc.b0.ijk",
                           "vox.nonocc.b0.head_in", "vox.nonocc.b0.head_out"})
    test::check_gsm_tensor(ref, name, traced(t, name));
  check_gaussians(out, "gs.b0.voxel.", gaussians.download(ctx));

  // Inputs that disagree with the configuration are internal errors, refused before anything is recorded.
  nn::VoxelHeadsGpuInputs bad = in;
  bad.front.front.pop_back();
  CHECK_THROWS_AS(nn::voxel_heads_gpu(B, g.heads, bad, 0, nullptr), std::invalid_argument);
}

TEST_CASE("gsm gpu: the voxel branch on two views matches the CPU reference") {
  const std::string dir = test::gsm_small_dir();
  if (dir.empty()) return;
  gpu::Context& ctx = test::gpu_context();
  VoxelGpuCase g(dir);
  const test::GsmTensors ref(dir + "intermediates.safetensors");
  const TwoViews two = with_second_view(g.inputs, drop_batch_axis(ref.get("enc.conv.out")));
  const nn::GsmPixelRays rays = nn::cast_gsm_pixel_rays(two.inputs, 0);
  const nn::CpuTensor effective = drop_batch_axis(nn::gsm_effective_mask(two.inputs));
  const nn::SparseGrid grid = nn::gsm_input_grid(two.inputs, 0);

  // The CPU reference.
  nn::GsmTrace cpu;
  const nn::VoxelBranchFeatures f =
      nn::voxel_branch_features(g.unet, g.weights, grid, two.features, rays.first_voxel, effective, 0, &cpu);
  nn::VoxelHeadsInputs hin;
  hin.grid = grid;
  hin.voxel_features = f.features;
  hin.front = f.front.front;
  hin.front_per_view = f.front.front_per_view;
  hin.image_features = two.features;
  hin.effective_mask = effective;
  hin.poses = two.inputs.poses;
  hin.intrinsics = two.inputs.intrinsics;
  const nn::VoxelGaussians want = nn::voxel_heads_forward(g.heads, g.weights, hin, 0, &cpu);

  // The views are not redundant: some front voxels are first hits of one view only, some of both.
  int64_t one_view = 0, both = 0;
  for (size_t r = 0; r < f.front.front.size(); ++r) {
    const int seen = f.front.front_per_view[2 * r] + f.front.front_per_view[2 * r + 1];
    one_view += seen == 1;
    both += seen == 2;
  }
  CHECK(one_view > 100);
  CHECK(both > 100);

  nn::LayerRecorder L(ctx, *g.store, "gsm-voxel-test");
  nn::VoxelBranchGpu B(ctx, L);
  nn::VoxelBranchGpuTrace trace;
  nn::VoxelBranchGpuOutputs got;
  const nn::DeviceTensor x = upload(two.features, two.features.shape, "gsm-conv-features");
  const double ms = run_recorded(L, [&] {
    got = nn::voxel_branch_gpu(B, g.unet, g.heads, grid, x, rays.first_voxel, effective, two.inputs.poses,
                               two.inputs.intrinsics, 0, &trace);
  });
  MESSAGE("lavapipe: the whole voxel branch on 2 views " << ms << " ms (" << grid.size() << " voxels, " << got.gaussians.count()
                                                         << " Gaussians)");
  const nn::GsmTrace t = trace.download(ctx);
  for (const auto& [name, w] : cpu.tensors) {
    CAPTURE(name);
    const nn::CpuTensor& have = traced(t, name);
    REQUIRE(have.shape == w.shape);
    const bool integer = name.find(".ijk") != std::string::npos || name.find("front") != std::string::npos;
    if (integer) {
      CHECK(have.data == w.data);
      continue;
    }
    const double e = nn::cpu::max_abs_over_std(have.data, w.data);
    std::printf("  %-44s %.3g of std\n", name.c_str(), e);
    CHECK(e <= 1e-4);
  }
  const nn::VoxelGaussians have = got.gaussians.download(ctx);
  REQUIRE(have.count() == want.count());
  CHECK(have.src_ijk == want.src_ijk);
  CHECK(have.src_level == want.src_level);
  CHECK(have.src_sub == want.src_sub);
  for (const auto& [name, p, q] : {std::tuple{"means", &have.means, &want.means}, {"scales", &have.scales, &want.scales},
                                   {"rotations", &have.rotations, &want.rotations}, {"opacities", &have.opacities, &want.opacities},
                                   {"colors", &have.colors, &want.colors}}) {
    CAPTURE(name);
    REQUIRE(p->shape == q->shape);
    const double e = nn::cpu::max_abs_over_std(p->data, q->data);
    std::printf("  gaussians.%-34s %.3g of std\n", name, e);
    CHECK(e <= 1e-4);
  }
}

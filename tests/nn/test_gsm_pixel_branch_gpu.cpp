// The GSM's pixel branch on the GPU (engine/nn/gsm/xunet_gpu.h, pixel_branch_gpu.h)
// on the official gsm_small case: the x-unet fed pix.unet_in (every pix.unet.*
// block and pix.unet_out), then the whole branch fed the reference's inputs of
// the stage (pix.voxel_depth, pre.grid_fg_mask, enc.dav2.out, as the CPU test
// does) through to pix.* and the pixel Gaussians gs.b0.pixel.*, all within 1e-4
// of the official tensors' std; then two views (the case view and a second one:
// the camera yawed by 4 degrees, every input map and the depth-patch draw
// mirrored) against the CPU reference (pixel_branch_forward), every traced tensor
// and the Gaussians (the same pixels, in the same order). Also the weights'
// GPU forms (add_xunet_gpu_tensors) and refused inputs. Runs under the
// validation layer; prints the branch's wall time on the test device.
#include <doctest/doctest.h>

#include "gpu_test_context.h"
#include "gsm_case.h"
#include "kernels/nn/conv_transpose2d.h"
#include "nn/gsm/gsm_gpu_weights.h"
#include "nn/gsm/gsm_inputs.h"
#include "nn/gsm/gsm_reference.h"
#include "nn/gsm/pixel_branch_gpu.h"
#include "nn/gsm/pixel_branch_reference.h"
#include "nn/gsm/xunet_gpu.h"
#include "nn/parameter_store.h"
#include "scene/input_error.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <tuple>

using namespace icube;

namespace {

const std::string kNet = "backbone.backbone_2d.net.";

nn::CpuTensor download(gpu::Context& ctx, const nn::DeviceTensor& t) {
  return nn::CpuTensor(t.shape, gpu::download_vector<float>(ctx, *t.buf, t.numel()));
}

nn::DeviceTensor upload(gpu::Context& ctx, const nn::CpuTensor& t, const char* name) {
  return {std::make_shared<gpu::Buffer>(gpu::upload_vector(ctx, t.data, name)), t.shape};
}

struct PixelGpuCase {
  std::string dir;
  nn::GsmConfig config;
  nn::GsmInputs inputs;
  nn::GsmWeights weights;
  nn::GsmGpuWeights gpu_weights;
  std::unique_ptr<nn::ParameterStore> store;

  explicit PixelGpuCase(const std::string& d)
      : dir(d), config(nn::read_gsm_config(d + "config.json")), inputs(nn::read_gsm_inputs(d + "inputs")),
        weights(nn::load_gsm_weights(d + "weights.safetensors")), gpu_weights(nn::gsm_gpu_weights(weights)) {
    // The pixel branch's tensors only (the other stages' GPU forms are their tests' business).
    std::vector<nn::ParamSpec> specs;
    for (const nn::ParamSpec& p : gpu_weights.specs)
      if (p.name.rfind("backbone.backbone_2d.", 0) == 0) specs.push_back(p);
    store = std::make_unique<nn::ParameterStore>(test::gpu_context(), specs, gpu_weights.tensors,
                                                 nn::ParameterStoreOptions{.network = "the GSM", .source = d + "weights.safetensors"});
  }
};

// The stage's inputs on the host: voxel depth [V, 1, H, W], grid mask [V, 1, H, W], DAV2 feature [V, C, h, w].
struct StageInputs {
  nn::CpuTensor voxel_depth, grid, dav2;
};

StageInputs reference_stage_inputs(const test::GsmTensors& ref, const nn::GsmInputs& in) {
  const int64_t V = in.batch * in.views;
  StageInputs s{ref.get("pix.voxel_depth"), ref.get("pre.grid_fg_mask"), ref.get("enc.dav2.out")};
  s.voxel_depth.shape = {V, 1, in.height, in.width};
  s.grid.shape = {V, 1, in.height, in.width};
  s.dav2.shape = {V, s.dav2.dim(2), s.dav2.dim(3), s.dav2.dim(4)};
  return s;
}

struct GpuBranchRun {
  std::vector<nn::PixelGaussians> gaussians;
  nn::GsmTrace trace;
  double seconds = 0.0;
};

GpuBranchRun run_gpu_branch(PixelGpuCase& g, const nn::GsmInputs& in, const StageInputs& s) {
  gpu::Context& ctx = test::gpu_context();
  nn::PixelBranchGpuInputs x;
  x.images = upload(ctx, nn::gsm_images_nchw(in), "pix-images");
  x.voxel_depth = upload(ctx, s.voxel_depth, "pix-voxel-depth");
  x.grid_foreground = upload(ctx, s.grid, "pix-grid-fg");
  x.foreground = upload(ctx, nn::pixel_branch_foreground(in), "pix-fg");
  x.dav2_feature = upload(ctx, s.dav2, "pix-dav2");
  nn::LayerRecorder L(ctx, *g.store, "gsm-pixel-test");
  nn::PixelBranchGpuTrace trace;
  nn::PixelBranchGpuOutput out;
  const auto t0 = std::chrono::steady_clock::now();
  ctx.submit_and_wait([&](gpu::CommandList& cmd) {
    L.begin(cmd);
    out = nn::pixel_branch_gpu(L, g.config.pixel, in, x, &trace);
    L.end();
  });
  GpuBranchRun r;
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  r.gaussians = nn::download_pixel_gaussians(ctx, g.config.pixel, in, out);
  r.trace = nn::download_pixel_branch_trace(ctx, in, trace);
  return r;
}

nn::CpuTensor src_tensor(const nn::PixelGaussians& g) {
  return nn::CpuTensor({g.count(), 4}, std::vector<float>(g.src.begin(), g.src.end()));
}

// The case's view with a second one appended: the camera yawed about the grid's z axis, the image, the masks,
// the depth-patch draw and the stage's input maps mirrored left-right.
std::pair<nn::GsmInputs, StageInputs> with_second_view(const nn::GsmInputs& one, const StageInputs& s1) {
  nn::GsmInputs in = one;
  const int64_t H = one.height, W = one.width;
  auto mirror_rows = [](std::vector<float>& dst, const std::vector<float>& src, int64_t rows, int64_t width, int64_t step) {
    for (int64_t r = 0; r < rows; ++r)
      for (int64_t c = 0; c < width; ++c)
        for (int64_t k = 0; k < step; ++k)
          dst[static_cast<size_t>((r * width + c) * step + k)] = src[static_cast<size_t>((r * width + (width - 1 - c)) * step + k)];
  };
  std::vector<float> img2(one.images.data.size());
  mirror_rows(img2, one.images.data, H, W, 3);
  std::vector<uint8_t> mask2(one.masks.size());
  for (int64_t r = 0; r < H; ++r)
    for (int64_t c = 0; c < W; ++c)
      for (int k = 0; k < 4; ++k) mask2[static_cast<size_t>((r * W + c) * 4 + k)] = one.masks[static_cast<size_t>((r * W + (W - 1 - c)) * 4 + k)];
  std::array<float, 16> pose2 = one.poses[0];
  const double a = 4.0 * 3.14159265358979 / 180.0, ca = std::cos(a), sa = std::sin(a);
  for (int col = 0; col < 3; ++col) {  // R2 = Rz(a) R
    const double x = pose2[static_cast<size_t>(col)], y = pose2[static_cast<size_t>(4 + col)];
    pose2[static_cast<size_t>(col)] = static_cast<float>(ca * x - sa * y);
    pose2[static_cast<size_t>(4 + col)] = static_cast<float>(sa * x + ca * y);
  }
  const int64_t pr = one.patch_rows(), pc = one.patch_cols();
  std::vector<uint8_t> keep2(one.depth_patch_keep.size());
  for (int64_t r = 0; r < pr; ++r)
    for (int64_t c = 0; c < pc; ++c) keep2[static_cast<size_t>(r * pc + c)] = one.depth_patch_keep[static_cast<size_t>(r * pc + (pc - 1 - c))];
  in.views = 2;
  in.images = nn::CpuTensor({1, 2, H, W, 3}, [&] {
    std::vector<float> v = one.images.data;
    v.insert(v.end(), img2.begin(), img2.end());
    return v;
  }());
  in.masks.insert(in.masks.end(), mask2.begin(), mask2.end());
  in.poses.push_back(pose2);
  in.intrinsics.push_back(one.intrinsics[0]);
  in.depth_patch_keep.insert(in.depth_patch_keep.end(), keep2.begin(), keep2.end());

  // Maps [1, C, h, w] -> [2, C, h, w] with the mirrored copy second.
  auto two = [&](const nn::CpuTensor& t) {
    const int64_t C = t.dim(1), h = t.dim(2), w = t.dim(3);
    nn::CpuTensor y({2, C, h, w});
    std::copy(t.data.begin(), t.data.end(), y.data.begin());
    std::vector<float> m(t.data.size());
    mirror_rows(m, t.data, C * h, w, 1);
    std::copy(m.begin(), m.end(), y.data.begin() + static_cast<int64_t>(t.data.size()));
    return y;
  };
  return {in, StageInputs{two(s1.voxel_depth), two(s1.grid), two(s1.dav2)}};
}

double error_of(const nn::CpuTensor& got, const nn::CpuTensor& want) {
  REQUIRE_MESSAGE(got.shape == want.shape, got.shape_text() << " != " << want.shape_text());
  return nn::cpu::max_abs_over_std(got.data, want.data);
}

}  // namespace

TEST_CASE("gsm gpu: the pixel branch's x-unet matches pix.unet.*") {
  // The weights' GPU forms, on a tiny synthetic x-unet.
  nn::GsmWeights tiny;
  tiny.tensors["n.init_conv.weight"] = nn::CpuTensor({2, 3, 1, 7, 7}, 0.5f);
  tiny.tensors["n.downs.0.3.1.weight"] = nn::CpuTensor({2, 8, 1, 1, 1}, [] {
    std::vector<float> v(16);
    for (size_t i = 0; i < v.size(); ++i) v[i] = static_cast<float>(i);
    return v;
  }());
  tiny.tensors["n.ups.0.3.weight"] = nn::CpuTensor({4, 3, 1, 4, 4}, 1.0f);
  tiny.tensors["n.downs.0.0.block1.norm.gamma"] = nn::CpuTensor({2, 1, 1, 1}, 2.0f);
  tiny.tensors["n.mid_attn.norm.gamma"] = nn::CpuTensor({1, 2, 1, 1, 1}, 3.0f);
  tiny.tensors["other.weight"] = nn::CpuTensor({2, 2, 1, 3, 3});
  std::map<std::string, nn::CpuTensor> forms;
  nn::add_xunet_gpu_tensors(tiny, forms, "n.");
  CHECK(forms.at("n.init_conv.weight").shape == std::vector<int64_t>{2, 3, 7, 7});
  CHECK(forms.at("n.downs.0.3.1.space_to_depth_weight").shape == std::vector<int64_t>{2, 2, 2, 2});
  CHECK(forms.at("n.downs.0.3.1.space_to_depth_weight").data == tiny.tensors.at("n.downs.0.3.1.weight").data);
  CHECK(forms.at("n.ups.0.3.transposed_weight").data ==
        kernels::nn::pack_conv_transpose2d_weights(tiny.tensors.at("n.ups.0.3.weight").data, 4, 3, 4, 4));
  CHECK(forms.at("n.downs.0.0.block1.norm.weight").data == std::vector<float>{2.0f, 2.0f});
  CHECK_FALSE(forms.count("n.downs.0.0.block1.norm.bias"));
  CHECK(forms.at("n.mid_attn.norm.weight").data == std::vector<float>{3.0f, 3.0f});
  CHECK(forms.at("n.mid_attn.norm.bias").data == std::vector<float>{0.0f, 0.0f});
  CHECK_FALSE(forms.count("other.weight"));
  tiny.tensors["n.bad.weight"] = nn::CpuTensor({2, 2, 3, 3, 3});
  CHECK_THROWS_AS(nn::add_xunet_gpu_tensors(tiny, forms, "n."), std::invalid_argument);

  const std::string dir = test::gsm_small_dir();
  if (dir.empty()) return;
  gpu::Context& ctx = test::gpu_context();
  PixelGpuCase g(dir);
  nn::check_pixel_branch_gpu(g.config.pixel, g.config.source);
  nn::XUnetConfig standardized = g.config.pixel.unet;
  standardized.weight_standardize = true;
  CHECK_THROWS_AS(nn::check_xunet_gpu(standardized, g.config.source), scene::InputError);

  const test::GsmTensors ref(dir + "intermediates.safetensors");
  const nn::DeviceTensor x = upload(ctx, ref.get("pix.unet_in"), "pix-unet-in");
  nn::LayerRecorder L(ctx, *g.store, "gsm-xunet-test");
  std::map<std::string, nn::DeviceTensor> trace;
  nn::DeviceTensor y;
  ctx.submit_and_wait([&](gpu::CommandList& cmd) {
    L.begin(cmd);
    y = nn::xunet_gpu(L, g.config.pixel.unet, kNet, x, &trace);
    L.end();
  });
  // init_conv, 4 down stages x 3, mid x 4, 3 up stages x 3, consolidator.
  CHECK(trace.size() == 1 + 4 * 3 + 4 + 3 * 3 + 1);
  for (const auto& [name, t] : trace) {
    REQUIRE_MESSAGE(ref.has(name), "the reference has no " << name);
    nn::CpuTensor got = download(ctx, t);
    got.shape = {t.shape[0], t.shape[1], 1, t.shape[2], t.shape[3]};
    test::check_gsm_tensor(ref, name, got);
  }
  test::check_gsm_tensor(ref, "pix.unet_out", download(ctx, y));
}

TEST_CASE("gsm gpu: the pixel branch matches pix.* and gs.b0.pixel.*") {
  const std::string dir = test::gsm_small_dir();
  if (dir.empty()) return;
  PixelGpuCase g(dir);
  const test::GsmTensors ref(dir + "intermediates.safetensors"), outputs(dir + "outputs.safetensors");
  const StageInputs s = reference_stage_inputs(ref, g.inputs);

  run_gpu_branch(g, g.inputs, s);  // the first run builds the pipelines
  const GpuBranchRun r = run_gpu_branch(g, g.inputs, s);
  std::printf("  pixel branch on the GPU (%s): %.3f s for %lld x %lld, %lld view(s)\n", test::gpu_context().info().name.c_str(),
              r.seconds, static_cast<long long>(g.inputs.height), static_cast<long long>(g.inputs.width),
              static_cast<long long>(g.inputs.batch * g.inputs.views));
  for (const char* name : {"pix.masked_voxel_depth", "pix.unet_in", "pix.unet.init_conv", "pix.unet.mid_attn", "pix.unet.consolidator",
                           "pix.unet_out", "pix.gs_params", "pix.gaussian_pixel_mask"}) {
    REQUIRE_MESSAGE(r.trace.tensors.count(name), name);
    test::check_gsm_tensor(ref, name, r.trace.tensors.at(name));
  }
  REQUIRE(r.gaussians.size() == 1);
  const nn::PixelGaussians& p = r.gaussians[0];
  test::check_gsm_tensor(outputs, "gs.b0.pixel.means", p.means);
  test::check_gsm_tensor(outputs, "gs.b0.pixel.scales", p.scales);
  test::check_gsm_tensor(outputs, "gs.b0.pixel.rotations", p.rotations);
  test::check_gsm_tensor(outputs, "gs.b0.pixel.opacities", p.opacities);
  test::check_gsm_tensor(outputs, "gs.b0.pixel.colors", p.colors);
  test::check_gsm_tensor(outputs, "gs.b0.pixel.src", src_tensor(p));

  // Refused inputs: a DAV2 feature for the wrong number of views, intrinsics of another image size.
  gpu::Context& ctx = test::gpu_context();
  nn::LayerRecorder L(ctx, *g.store, "gsm-pixel-refusals");
  nn::PixelBranchGpuInputs x;
  x.images = upload(ctx, nn::gsm_images_nchw(g.inputs), "pix-images");
  x.voxel_depth = upload(ctx, s.voxel_depth, "pix-voxel-depth");
  x.grid_foreground = upload(ctx, s.grid, "pix-grid-fg");
  x.foreground = upload(ctx, nn::pixel_branch_foreground(g.inputs), "pix-fg");
  nn::CpuTensor two_views = s.dav2;
  two_views.shape[0] = 2;
  two_views.data.resize(two_views.data.size() * 2);
  const nn::DeviceTensor wrong_dav2 = upload(ctx, two_views, "pix-dav2-wrong"), dav2 = upload(ctx, s.dav2, "pix-dav2");
  nn::GsmInputs other_size = g.inputs;
  other_size.intrinsics[0][4] = 320.0f;
  ctx.submit_and_wait([&](gpu::CommandList& cmd) {
    L.begin(cmd);
    x.dav2_feature = wrong_dav2;
    CHECK_THROWS_WITH_AS(nn::pixel_branch_gpu(L, g.config.pixel, g.inputs, x, nullptr), doctest::Contains("DAV2 feature"),
                         std::invalid_argument);
    x.dav2_feature = dav2;
    CHECK_THROWS_AS(nn::pixel_branch_gpu(L, g.config.pixel, other_size, x, nullptr), scene::InputError);
    L.end();
  });
}

TEST_CASE("gsm gpu: the pixel branch on two views matches the CPU reference") {
  const std::string dir = test::gsm_small_dir();
  if (dir.empty()) return;
  PixelGpuCase g(dir);
  const test::GsmTensors ref(dir + "intermediates.safetensors");
  const auto [in, s] = with_second_view(g.inputs, reference_stage_inputs(ref, g.inputs));

  nn::GsmTrace cpu_trace;
  nn::CpuTensor voxel_depth = s.voxel_depth;
  const std::vector<uint8_t> grid(s.grid.data.begin(), s.grid.data.end());
  const std::vector<nn::PixelGaussians> want = nn::pixel_branch_forward(g.config.pixel, g.weights, in, voxel_depth, grid, s.dav2, &cpu_trace);
  const GpuBranchRun r = run_gpu_branch(g, in, s);

  size_t compared = 0;
  for (const auto& [name, t] : r.trace.tensors) {
    if (!cpu_trace.tensors.count(name)) continue;
    CAPTURE(name);
    const double e = error_of(t, cpu_trace.tensors.at(name));
    std::printf("  two views: %-32s %.3g of std\n", name.c_str(), e);
    CHECK(e <= 1e-4);
    ++compared;
  }
  CHECK(compared == 5 + 1 + 4 * 3 + 4 + 3 * 3 + 1);  // five pix.* and every pix.unet.* block

  REQUIRE(r.gaussians.size() == 1);
  REQUIRE(want.size() == 1);
  const nn::PixelGaussians &got = r.gaussians[0], &w = want[0];
  CHECK(got.count() > 0);
  CHECK(got.src == w.src);
  REQUIRE(got.count() == w.count());
  int views_seen[2] = {0, 0};
  for (int64_t k = 0; k < got.count(); ++k) ++views_seen[got.src[static_cast<size_t>(k * 4)]];
  CHECK(views_seen[0] > 0);
  CHECK(views_seen[1] > 0);
  for (const auto& [name, a, b] : {std::tuple{"means", &got.means, &w.means}, std::tuple{"scales", &got.scales, &w.scales},
                                   std::tuple{"rotations", &got.rotations, &w.rotations},
                                   std::tuple{"opacities", &got.opacities, &w.opacities}, std::tuple{"colors", &got.colors, &w.colors}}) {
    CAPTURE(name);
    const double e = error_of(*a, *b);
    std::printf("  two views: pixel Gaussians' %-16s %.3g of std\n", name, e);
    CHECK(e <= 1e-4);
  }
}

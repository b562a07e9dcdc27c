// The GSM's Depth-Anything-V2 features on the GPU (engine/nn/gsm/dav2_gpu.h) on the
// official gsm_small case: every enc.dav2.* intermediate and the output within 1e-4 of
// std of the official tensors and of the CPU reference (dav2_features) on the same input,
// then two views (the case image and its left-right mirror) against the CPU reference,
// with the position embeddings taken from the cache the first forward filled. Runs under
// the validation layer; prints the forward's wall time on the test device.
#include <doctest/doctest.h>

#include "gpu_test_context.h"
#include "gsm_case.h"
#include "nn/gsm/dav2_gpu.h"
#include "nn/gsm/gsm_gpu_weights.h"
#include "nn/gsm/gsm_inputs.h"
#include "nn/gsm/gsm_reference.h"
#include "nn/parameter_store.h"
#include "scene/input_error.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

using namespace icube;

namespace {

nn::CpuTensor download(gpu::Context& ctx, const nn::DeviceTensor& t) {
  return nn::CpuTensor(t.shape, gpu::download_vector<float>(ctx, *t.buf, t.numel()));
}

// [1, 3, H, W] -> [2, 3, H, W]: the image, then its left-right mirror.
nn::CpuTensor with_mirror(const nn::CpuTensor& image) {
  const int64_t H = image.dim(2), W = image.dim(3);
  nn::CpuTensor x({2, 3, H, W});
  std::copy(image.data.begin(), image.data.end(), x.data.begin());
  for (int64_t r = 0; r < 3 * H; ++r)
    for (int64_t c = 0; c < W; ++c)
      x.data[static_cast<size_t>((3 * H + r) * W + c)] = image.data[static_cast<size_t>(r * W + (W - 1 - c))];
  return x;
}

std::vector<std::string> dav2_names(const nn::Dav2Config& cfg) {
  std::vector<std::string> names = {"enc.dav2.pixel_values", "enc.dav2.pos_embed_interp", "enc.dav2.embeddings"};
  for (int64_t i = 0; i < cfg.num_layers; ++i) names.push_back("enc.dav2.layer." + std::to_string(i));
  for (const char* stage : {"feature_maps", "reassemble", "neck_conv", "fusion"})
    for (size_t k = 0; k < cfg.out_indices.size(); ++k) names.push_back(std::string("enc.dav2.") + stage + "." + std::to_string(k));
  for (size_t j = 0; j + 1 < cfg.upsampler.size(); ++j) names.push_back("enc.dav2.upsampler." + std::to_string(j));
  names.push_back("enc.dav2.out");
  return names;
}

struct GpuRun {
  nn::Dav2GpuTrace trace;
  nn::DeviceTensor out;
  double seconds = 0;
};

GpuRun run_gpu(gpu::Context& ctx, nn::LayerRecorder& L, const nn::Dav2Config& cfg, const nn::CpuTensor& images,
               nn::Dav2PositionEmbeddings& positions) {
  const nn::DeviceTensor x{std::make_shared<gpu::Buffer>(gpu::upload_vector(ctx, images.data, "dav2-images")), images.shape};
  GpuRun r;
  const auto t0 = std::chrono::steady_clock::now();
  ctx.submit_and_wait([&](gpu::CommandList& cmd) {
    L.begin(cmd);
    r.out = nn::dav2_gpu(L, cfg, x, &r.trace, &positions);
    L.end();
  });
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

// Every name of `names` in the GPU trace, against the CPU reference's trace (and the official tensors when given).
void compare(gpu::Context& ctx, const GpuRun& gpu_run, const nn::GsmTrace& cpu, const std::vector<std::string>& names, int64_t batch,
             const test::GsmTensors* official) {
  const nn::GsmTrace got_all = nn::download_dav2_trace(ctx, gpu_run.trace, batch);
  for (const std::string& name : names) {
    REQUIRE_MESSAGE(got_all.tensors.count(name) == 1, "the GPU stage did not record " << name);
    REQUIRE_MESSAGE(cpu.tensors.count(name) == 1, "the CPU reference did not record " << name);
    const nn::CpuTensor& got = got_all.tensors.at(name);
    if (official) test::check_gsm_tensor(*official, name, got);
    const nn::CpuTensor& want = cpu.tensors.at(name);
    REQUIRE_MESSAGE(got.shape == want.shape, name << ": GPU " << got.shape_text() << ", CPU reference " << want.shape_text());
    const double e = nn::cpu::max_abs_over_std(got.data, want.data);
    std::printf("  %-44s %.3g of std against the CPU reference\n", name.c_str(), e);
    CHECK_MESSAGE(e <= 1e-4, name << ": against the CPU reference max |got - ref| / std(ref) = " << e);
  }
  CHECK(gpu_run.trace.tensors.size() == names.size());
}

}  // namespace

TEST_CASE("gsm gpu: Depth-Anything-V2 features match enc.dav2.*") {
  const std::string dir = test::gsm_small_dir();
  if (dir.empty()) return;
  gpu::Context& ctx = test::gpu_context();
  const nn::GsmConfig config = nn::read_gsm_config(dir + "config.json");
  const nn::Dav2Config& cfg = config.dav2;
  nn::check_dav2_gpu(cfg, config.source);
  const nn::GsmWeights weights = nn::load_gsm_weights(dir + "weights.safetensors");
  const nn::GsmGpuWeights gpu_weights = nn::gsm_gpu_weights(weights);
  // The stage's own tensors only (the store of the whole GSM is the GSM network's concern).
  std::vector<nn::ParamSpec> specs;
  for (const nn::ParamSpec& p : gpu_weights.specs)
    if (p.name.rfind("img_encoder.encoders.dav2.", 0) == 0) specs.push_back(p);
  const nn::ParameterStore store(ctx, specs, gpu_weights.tensors,
                                 nn::ParameterStoreOptions{.network = "the GSM", .source = dir + "weights.safetensors"});
  const nn::GsmInputs in = nn::read_gsm_inputs(dir + "inputs");
  const nn::CpuTensor images = nn::gsm_images_nchw(in);
  REQUIRE(images.dim(0) == 1);
  const std::vector<std::string> names = dav2_names(cfg);
  const test::GsmTensors official(dir + "intermediates.safetensors");

  nn::LayerRecorder L(ctx, store, "dav2-test");
  nn::Dav2PositionEmbeddings positions;

  // One view (the case): the official intermediates and the CPU reference.
  const GpuRun one = run_gpu(ctx, L, cfg, images, positions);
  nn::GsmTrace cpu_one;
  const nn::CpuTensor cpu_out = nn::dav2_features(cfg, weights, images, &cpu_one, in.batch);
  std::printf("Depth-Anything-V2 features (GPU) on gsm_small, against the official tensors and the CPU reference:\n");
  compare(ctx, one, cpu_one, names, in.batch, &official);
  CHECK(one.out.shape == cpu_out.shape);
  CHECK(positions.size() == 1);

  // The same forward again (pipelines built, position embeddings cached): the same values.
  const GpuRun again = run_gpu(ctx, L, cfg, images, positions);
  CHECK(download(ctx, again.out).data == download(ctx, one.out).data);
  std::printf("  forward of 1 view at %lldx%lld: %.3f s (first, with pipeline creation), %.3f s (again)\n",
              static_cast<long long>(images.dim(2)), static_cast<long long>(images.dim(3)), one.seconds, again.seconds);

  // Two views (the image and its mirror) against the CPU reference, the cached position embeddings reused.
  const nn::CpuTensor two_views = with_mirror(images);
  const GpuRun two = run_gpu(ctx, L, cfg, two_views, positions);
  nn::GsmTrace cpu_two;
  nn::dav2_features(cfg, weights, two_views, &cpu_two, 1);
  std::printf("Depth-Anything-V2 features (GPU), 2 views, against the CPU reference (%.3f s):\n", two.seconds);
  compare(ctx, two, cpu_two, names, 1, nullptr);
  CHECK(positions.size() == 1);
}

TEST_CASE("gsm gpu: Depth-Anything-V2 settings the GPU stage does not implement are refused by key") {
  nn::Dav2Config cfg;
  CHECK_NOTHROW(nn::check_dav2_gpu(cfg, "config.json"));
  cfg.upsampler.push_back({8, true, false, false});
  CHECK_NOTHROW(nn::check_dav2_gpu(cfg, "config.json"));
  cfg.use_swiglu_ffn = true;
  CHECK_THROWS_WITH_AS(nn::check_dav2_gpu(cfg, "config.json"), doctest::Contains("use_swiglu_ffn"), scene::InputError);
  cfg.use_swiglu_ffn = false;
  cfg.upsampler.push_back({8, false, true, false});
  CHECK_THROWS_WITH_AS(nn::check_dav2_gpu(cfg, "config.json"), doctest::Contains("out_downsample_list"), scene::InputError);
  cfg.upsampler.back() = {8, false, false, true};
  CHECK_THROWS_WITH_AS(nn::check_dav2_gpu(cfg, "config.json"), doctest::Contains("out_use_gn_list"), scene::InputError);
}

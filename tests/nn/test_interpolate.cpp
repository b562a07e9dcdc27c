// interpolate on the GPU (kernels/nn/interpolate.h, shaders/nn/interpolate.comp)
// against the CPU reference (nn::cpu::resize_*): bilinear and bicubic with and
// without align_corners, nearest; odd sizes, up and down scaling at the GSM's
// shapes (96x160 -> 56x84, the DAV2 input; 32x48 -> 128x192; the 37x37
// position grid -> 4x6 bicubic; corner-aligned x2), 1-pixel maps, extreme and
// mixed-magnitude values; windows of planes under capped bindings, and the
// refusal of a plane beyond one binding. Bound per element: 1e-6 + 1e-5 sum
// |tap x| (bilinear: exactly resize_bilinear(|x|); bicubic: the taps' |weights|
// sum to at most 1.375 per axis, times the largest |x| in reach); nearest is
// exact. Then the official gsm_small case: enc.dav2.pos_embed_interp and
// enc.dav2.pixel_values from the GPU resize. The CPU reference on known values.
// Runs under the validation layer.
#include <doctest/doctest.h>

#include "gpu_test_context.h"
#include "gsm_case.h"
#include "kernels/nn/interpolate.h"
#include "nn/gsm/gsm_inputs.h"
#include "scene/atomic_file.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>

using namespace icube;
using kernels::nn::InterpolateMode;
using kernels::nn::InterpolateShape;

namespace {

nn::CpuTensor random_tensor(std::vector<int64_t> shape, uint32_t seed, float scale) {
  nn::CpuTensor t(std::move(shape));
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-scale, scale);
  for (float& v : t.data) v = u(rng);
  return t;
}

// Values spread over 2^-60 .. 2^60 in magnitude, both signs.
nn::CpuTensor mixed_magnitudes(std::vector<int64_t> shape, uint32_t seed) {
  nn::CpuTensor t(std::move(shape));
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  std::uniform_int_distribution<int> e(-60, 60);
  for (float& v : t.data) v = std::ldexp(u(rng), e(rng));
  return t;
}

nn::CpuTensor reference(const nn::CpuTensor& x, const InterpolateShape& s) {
  switch (s.mode) {
    case InterpolateMode::nearest: return nn::cpu::resize_nearest(x, s.out_h, s.out_w);
    case InterpolateMode::bilinear: return nn::cpu::resize_bilinear(x, s.out_h, s.out_w, s.align_corners);
    case InterpolateMode::bicubic: return nn::cpu::resize_bicubic(x, s.out_h, s.out_w, s.align_corners);
  }
  return {};
}

// The source rows (or columns) an output index may read: floor(src) - 1 .. floor(src) + 2, widened by one.
std::pair<int64_t, int64_t> reach(int64_t dst, int64_t in, int64_t out, bool align_corners) {
  const double src = align_corners ? (out > 1 ? static_cast<double>(dst) * static_cast<double>(in - 1) / static_cast<double>(out - 1) : 0.0)
                                   : (static_cast<double>(dst) + 0.5) * static_cast<double>(in) / static_cast<double>(out) - 0.5;
  const int64_t f = static_cast<int64_t>(std::floor(src));
  return {std::clamp<int64_t>(f - 2, 0, in - 1), std::clamp<int64_t>(f + 3, 0, in - 1)};
}

// Per output element: an upper bound of sum |tap weight * x| (see the file comment).
std::vector<double> tap_bound(const nn::CpuTensor& x, const InterpolateShape& s) {
  const int64_t H = s.in_h, W = s.in_w, OH = s.out_h, OW = s.out_w, planes = int64_t{s.batch} * s.channels;
  std::vector<double> bound(static_cast<size_t>(planes * OH * OW), 0.0);
  if (s.mode == InterpolateMode::bilinear) {
    nn::CpuTensor ax = x;
    for (float& v : ax.data) v = std::abs(v);
    const nn::CpuTensor b = nn::cpu::resize_bilinear(ax, OH, OW, s.align_corners);
    for (size_t i = 0; i < bound.size(); ++i) bound[i] = b.data[i];
    return bound;
  }
  for (int64_t p = 0; p < planes; ++p)
    for (int64_t oy = 0; oy < OH; ++oy) {
      const auto [r0, r1] = reach(oy, H, OH, s.align_corners);
      for (int64_t ox = 0; ox < OW; ++ox) {
        const auto [c0, c1] = reach(ox, W, OW, s.align_corners);
        double m = 0.0;
        for (int64_t r = r0; r <= r1; ++r)
          for (int64_t c = c0; c <= c1; ++c) m = std::max(m, std::abs(static_cast<double>(x.data[static_cast<size_t>((p * H + r) * W + c)])));
        bound[static_cast<size_t>((p * OH + oy) * OW + ox)] = 1.375 * 1.375 * m;
      }
    }
  return bound;
}

std::vector<float> run_gpu(const nn::CpuTensor& x, const InterpolateShape& s, uint64_t max_binding_bytes = 0) {
  gpu::Context& ctx = test::gpu_context();
  const size_t out_count = static_cast<size_t>(uint64_t{s.batch} * s.channels * s.out_h * s.out_w);
  gpu::Buffer xb = gpu::upload_vector(ctx, x.data, "interpolate-x");
  gpu::Buffer yb(ctx, out_count * 4, gpu::MemoryUsage::DeviceLocal, "interpolate-y");
  kernels::nn::Interpolate interpolate(ctx);
  interpolate.set_max_binding_bytes(max_binding_bytes);
  ctx.submit_and_wait([&](gpu::CommandList& cmd) { interpolate.record(cmd, s, xb, yb); });
  return gpu::download_vector<float>(ctx, yb, out_count);
}

// Returns the worst err / tol (for the margin), checking every element.
double check_interpolate(const InterpolateShape& s, const nn::CpuTensor& x, uint64_t max_binding_bytes = 0) {
  CAPTURE(s.batch);
  CAPTURE(s.channels);
  CAPTURE(s.in_h);
  CAPTURE(s.in_w);
  CAPTURE(s.out_h);
  CAPTURE(s.out_w);
  CAPTURE(static_cast<int>(s.mode));
  CAPTURE(s.align_corners);
  CAPTURE(max_binding_bytes);
  const nn::CpuTensor want = reference(x, s);
  const std::vector<double> bound = tap_bound(x, s);
  const std::vector<float> got = run_gpu(x, s, max_binding_bytes);
  const bool exact = s.mode == InterpolateMode::nearest;
  size_t bad = 0;
  double worst = 0.0;
  for (size_t i = 0; i < got.size(); ++i) {
    const double err = std::abs(static_cast<double>(got[i]) - static_cast<double>(want.data[i]));
    const double tol = exact ? 0.0 : 1e-6 + 1e-5 * bound[i];
    if (tol > 0.0) worst = std::max(worst, err / tol);
    if (!(err <= tol) && ++bad <= 5)
      std::printf("  interpolate mismatch at %zu: got %.9g want %.9g (tol %.3g)\n", i, static_cast<double>(got[i]),
                  static_cast<double>(want.data[i]), tol);
  }
  CHECK(bad == 0);
  return worst;
}

InterpolateShape shape(uint32_t b, uint32_t c, uint32_t h, uint32_t w, uint32_t oh, uint32_t ow, InterpolateMode m, bool align) {
  return InterpolateShape{b, c, h, w, oh, ow, m, align};
}

nn::CpuTensor input_for(const InterpolateShape& s, uint32_t seed, float scale = 1.0f) {
  return random_tensor({s.batch, s.channels, s.in_h, s.in_w}, seed, scale);
}

}  // namespace

TEST_CASE("interpolate gpu: bilinear, bicubic and nearest against the CPU reference") {
  const auto L = InterpolateMode::bilinear, C = InterpolateMode::bicubic, N = InterpolateMode::nearest;
  double worst = 0.0;
  uint32_t seed = 1;
  for (const InterpolateShape& s : {
           shape(1, 3, 96, 160, 56, 84, L, false),    // the DAV2 input resize
           shape(2, 3, 32, 48, 128, 192, L, false),   // x4 up, batch 2
           shape(1, 7, 37, 37, 4, 6, C, false),       // the position grid to the patch grid
           shape(2, 3, 7, 11, 14, 22, L, true),       // the DPT fusion's corner-aligned x2
           shape(1, 2, 5, 7, 23, 31, C, false),       // bicubic up: clamped taps and negative positions at the borders
           shape(1, 3, 9, 13, 20, 7, C, true),        // bicubic corner-aligned, up in y and down in x
           shape(2, 2, 13, 9, 5, 17, L, false),       // odd down / up mix
           shape(1, 2, 9, 10, 9, 10, L, false),       // same size
           shape(1, 2, 9, 10, 9, 10, C, true),
           shape(1, 1, 1, 1, 5, 4, L, false),         // a one-pixel map
           shape(1, 1, 1, 1, 3, 2, C, true),
           shape(1, 2, 6, 5, 1, 1, L, true),          // one output pixel (corner-aligned: the first input pixel)
           shape(1, 2, 6, 5, 1, 1, C, false),
       }) {
    worst = std::max(worst, check_interpolate(s, input_for(s, seed++)));
  }
  for (const InterpolateShape& s : {
           shape(2, 3, 5, 7, 11, 3, N, false),     // up in y, down in x
           shape(1, 2, 13, 17, 26, 34, N, false),  // nearest x2 (the upsampler's)
           shape(1, 1, 14, 14, 20, 20, N, false),  // 14 -> 20: floor(10 * 14 / 20) = 7 exactly
           shape(1, 1, 1, 1, 3, 3, N, false),
       }) {
    check_interpolate(s, input_for(s, seed++));
  }
  // Extreme values: large magnitudes, and magnitudes spread over 2^-60 .. 2^60 side by side.
  for (const InterpolateMode m : {L, C, N}) {
    const InterpolateShape up = shape(1, 3, 11, 9, 25, 20, m, false), down = shape(1, 2, 29, 31, 8, 10, m, m != N);
    worst = std::max(worst, check_interpolate(up, input_for(up, seed++, 1e30f)));
    worst = std::max(worst, check_interpolate(down, mixed_magnitudes({1, 2, 29, 31}, seed++)));
  }
  MESSAGE("interpolate: worst |gpu - cpu| / bound = " << worst);
}

TEST_CASE("interpolate gpu: windows of planes under a capped binding") {
  gpu::Context& ctx = test::gpu_context();
  const uint64_t align = std::max<uint64_t>({4, ctx.info().min_storage_buffer_offset_alignment, ctx.info().min_texel_buffer_offset_alignment});
  double worst = 0.0;
  // 2 planes of 13x11 inputs a window (the output planes are smaller): 5 windows at unaligned offsets.
  const InterpolateShape down = shape(2, 5, 13, 11, 7, 9, InterpolateMode::bilinear, false);
  worst = std::max(worst, check_interpolate(down, input_for(down, 201), 2 * 13 * 11 * 4 + align));
  // 3 output planes of 17x13 a window (larger than the inputs), 7 planes: windows of 3, 3, 1.
  const InterpolateShape up = shape(1, 7, 6, 5, 17, 13, InterpolateMode::bicubic, true);
  worst = std::max(worst, check_interpolate(up, input_for(up, 202), 3 * 17 * 13 * 4 + align));
  // One plane a window.
  const InterpolateShape near = shape(3, 1, 9, 7, 4, 3, InterpolateMode::nearest, false);
  check_interpolate(near, input_for(near, 203), 9 * 7 * 4 + align);
  MESSAGE("interpolate windows: worst |gpu - cpu| / bound = " << worst);

  // A single output plane beyond the binding is refused by size.
  gpu::Buffer xb(ctx, 64 * 4), yb(ctx, 64 * 64 * 4);
  kernels::nn::Interpolate interpolate(ctx);
  interpolate.set_max_binding_bytes(1024);
  ctx.submit_and_wait([&](gpu::CommandList& cmd) {
    CHECK_THROWS_WITH_AS(interpolate.record(cmd, shape(1, 1, 8, 8, 64, 64, InterpolateMode::bilinear, false), xb, yb),
                         doctest::Contains("8 x 8 -> 64 x 64 plane (16384 bytes) exceeds one storage binding"),
                         std::invalid_argument);
    CHECK_THROWS_WITH_AS(interpolate.record(cmd, shape(1, 1, 8, 8, 4, 4, InterpolateMode::nearest, true), xb, yb),
                         doctest::Contains("align_corners"), std::invalid_argument);
    CHECK_THROWS_WITH_AS(interpolate.record(cmd, shape(2, 1, 8, 8, 4, 4, InterpolateMode::bilinear, false), xb, yb),
                         doctest::Contains("input buffer holds 256 bytes, needs 512"), std::invalid_argument);
  });
}

TEST_CASE("interpolate gpu: the official gsm_small position grid and DAV2 input resize") {
  const std::string dir = test::gsm_small_dir();
  if (dir.empty()) return;
  const nlohmann::json config = nlohmann::json::parse(scene::read_file(dir + "config.json"));
  const int64_t patch = config.at("dav2_config").at("backbone_config").at("patch_size").get<int64_t>();
  const nn::GsmWeights w = nn::load_gsm_weights(dir + "weights.safetensors");
  const test::GsmTensors ref(dir + "intermediates.safetensors");
  const nn::CpuTensor want_pixels = ref.get("enc.dav2.pixel_values");
  const uint32_t IH = static_cast<uint32_t>(want_pixels.dim(2)), IW = static_cast<uint32_t>(want_pixels.dim(3));

  // Dinov2Embeddings.interpolate_pos_encoding: the G x G grid of [1, 1 + G^2, C] resized bicubically
  // (align_corners false, by output size) to the patch grid, the CLS entry unchanged.
  const nn::CpuTensor& pos = w.at("img_encoder.encoders.dav2.model.backbone.embeddings.position_embeddings");
  const int64_t C = pos.dim(2), G = static_cast<int64_t>(std::lround(std::sqrt(static_cast<double>(pos.dim(1) - 1))));
  REQUIRE(G * G + 1 == pos.dim(1));
  const int64_t gh = IH / patch, gw = IW / patch;
  nn::CpuTensor grid({1, C, G, G});
  for (int64_t p = 0; p < G * G; ++p)
    for (int64_t c = 0; c < C; ++c) grid.data[static_cast<size_t>(c * G * G + p)] = pos.data[static_cast<size_t>((1 + p) * C + c)];
  const InterpolateShape s = shape(1, static_cast<uint32_t>(C), static_cast<uint32_t>(G), static_cast<uint32_t>(G),
                                   static_cast<uint32_t>(gh), static_cast<uint32_t>(gw), InterpolateMode::bicubic, false);
  const std::vector<float> resized = run_gpu(grid, s);
  nn::CpuTensor pos_interp({1, 1 + gh * gw, C});
  std::copy(pos.data.begin(), pos.data.begin() + C, pos_interp.data.begin());
  for (int64_t p = 0; p < gh * gw; ++p)
    for (int64_t c = 0; c < C; ++c)
      pos_interp.data[static_cast<size_t>((1 + p) * C + c)] = resized[static_cast<size_t>(c * gh * gw + p)];
  test::check_gsm_tensor(ref, "enc.dav2.pos_embed_interp", pos_interp);

  // The [0, 1] views resized bilinearly (half-pixel centres) to the DAV2 input, then ImageNet-normalised.
  const nn::GsmInputs in = nn::read_gsm_inputs(dir + "inputs");
  const nn::CpuTensor images = nn::gsm_images_nchw(in);
  const InterpolateShape r = shape(static_cast<uint32_t>(images.dim(0)), 3, static_cast<uint32_t>(in.height),
                                   static_cast<uint32_t>(in.width), IH, IW, InterpolateMode::bilinear, false);
  nn::CpuTensor pixels({images.dim(0), 3, IH, IW});
  pixels.data = run_gpu(images, r);
  const float mean[3] = {0.485f, 0.456f, 0.406f}, stdev[3] = {0.229f, 0.224f, 0.225f};
  for (size_t i = 0; i < pixels.data.size(); ++i) {
    const size_t c = i / (size_t{IH} * IW) % 3;
    pixels.data[i] = (pixels.data[i] - mean[c]) / stdev[c];
  }
  test::check_gsm_tensor(ref, "enc.dav2.pixel_values", pixels);
}

TEST_CASE("interpolate cpu: known values of bilinear, bicubic and nearest") {
  nn::CpuTensor x({1, 1, 2, 2}, {0.0f, 1.0f, 2.0f, 3.0f});
  // Bilinear 2x2 -> 4x4, half-pixel centres: sources -0.25 (clamped to 0), 0.25, 0.75, 1.25 per axis.
  CHECK(test::allclose(nn::cpu::resize_bilinear(x, 4, 4, false).data,
                       {0.0f, 0.25f, 0.75f, 1.0f, 0.5f, 0.75f, 1.25f, 1.5f, 1.5f, 1.75f, 2.25f, 2.5f, 2.0f, 2.25f, 2.75f, 3.0f},
                       1e-7, 0.0, "bilinear"));
  // Corner-aligned 2 -> 3: the midpoint.
  CHECK(test::allclose(nn::cpu::resize_bilinear(x, 3, 3, true).data, {0.0f, 0.5f, 1.0f, 1.0f, 1.5f, 2.0f, 2.0f, 2.5f, 3.0f},
                       1e-7, 0.0, "bilinear aligned"));
  // Bicubic [0, 1] -> 4 along x (rows equal): at source -0.25 (floor -1, t = 0.75) the taps are
  // x[-2..1] clamped = 0, 0, 0, 1, so the value is w3(0.75) = a (1 - t) t^2 = -0.10546875; at 0.25
  // (t = 0.25) w2 + w3 = 0.26171875 - 0.03515625 = 0.2265625; the rest by symmetry.
  nn::CpuTensor row({1, 1, 1, 2}, {0.0f, 1.0f});
  CHECK(test::allclose(nn::cpu::resize_bicubic(row, 1, 4, false).data, {-0.10546875f, 0.2265625f, 0.7734375f, 1.10546875f},
                       1e-7, 0.0, "bicubic"));
  // Nearest 3 -> 7: floor(dst * 3 / 7).
  nn::CpuTensor three({1, 1, 1, 3}, {10.0f, 20.0f, 30.0f});
  CHECK(nn::cpu::resize_nearest(three, 1, 7).data == std::vector<float>{10, 10, 10, 20, 20, 30, 30});
}

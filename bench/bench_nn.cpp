// icube-bench-nn: the network layer's kernels against their CPU references and,
// with --torch, PyTorch's CPU ops on the same tensors, side by side in one run:
// conv3d (dense NCDHW, 3x3x3 and 1x1, every kernel path side by side: --conv-paths; --released-levels adds the released
// model's 64^3 and 32^3 levels), GroupNorm (+ scale-shift + SiLU) and
// attention at the diffusion UNet's shapes; GPU time per record (submit + wait,
// after a warm-up), GFLOP/s or GB/s, and the max difference to each competitor
// in the same run. --unet-case: the official unet_small case in fp32 and fp16
// weights (and bench/torch_unet.py); --unet CONFIG: one whole forward. See
// bench/README.md.
#include "gpu/context.h"
#include "kernels/nn/conv3d.h"
#include "kernels/nn/float16.h"
#include "kernels/nn/group_norm.h"
#include "nn/unet_config.h"
#include "nn/unet_gpu.h"
#include "nn/unet_reference.h"
#include "nn/safetensors.h"
#include "nn/weights.h"
#include "kernels/nn/cpu_tensor.h"
#include "kernels/nn/elementwise.h"
#include "kernels/nn/attention.h"
#include "world/npy.h"
#include "conv_variants.h"
#include "device_peaks.h"
#include "torch_side.h"

#include <nlohmann/json.hpp>
#include <sys/wait.h>
#include <unistd.h>
#include <filesystem>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <thread>

#include <CLI/CLI.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>
#include <map>
#include <string>
#include <vector>

using namespace icube;
using bench::TorchSide;
using bench::python_with_torch;
using bench::run_torch_unet;
using Clock = std::chrono::steady_clock;

namespace {

double ms_since(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

struct Stats {
  double min = 0, median = 0;
};
Stats stats(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return {v.front(), v[v.size() / 2]};
}


double max_rel(const std::vector<float>& got, const std::vector<float>& want) {
  double mx = 0, ref = 0;
  for (size_t i = 0; i < std::min(got.size(), want.size()); ++i) {
    mx = std::max(mx, std::abs(static_cast<double>(got[i]) - static_cast<double>(want[i])));
    ref = std::max(ref, std::abs(static_cast<double>(want[i])));
  }
  return got.size() == want.size() ? mx / std::max(ref, 1e-30) : std::numeric_limits<double>::infinity();
}

}  // namespace

// The benchmark's settings and one method per table; main parses the options into it and runs the tables.
struct NnBench {
  int runs = 5, warmup = 1;
  double cpu_limit_gflop = 3.0;
  bool quick = false;
  std::string unet_config;
  std::vector<int64_t> unet_grid{8, 16, 24};
  int64_t unet_batch = 1;
  std::string only;
  bool released_levels = false;
  bool with_torch = false;
  std::string unet_case;
  bool unet_no_cpu = false;
  std::string unet_precision = "fp32";
  std::vector<std::string> conv_variants{"register", "tiled", "tiled-fp16", "coopmat-fp16"};
  gpu::Context* ctx_ptr = nullptr;
  const bench::DevicePeak* peak = nullptr;  // the device's published peaks, when known (device_peaks.h)
  TorchSide torch_side;

  int conv3d_table();
  int group_norm_table();
  int attention_table();
  int unet_case_run();
  int unet_forward_run();
};

int NnBench::conv3d_table() {
  gpu::Context& ctx = *ctx_ptr;
  struct Case {
    const char* what;
    kernels::nn::Conv3dShape s;
  };
  std::vector<Case> cases = {
      {"unet_small in 16->32, 8x16x24", {1, 16, 32, 8, 16, 24, 3}},
      {"unet_small L0 32->32, 8x16x24", {1, 32, 32, 8, 16, 24, 3}},
      {"unet_small L1 64->64, 4x8x12", {1, 64, 64, 4, 8, 12, 3}},
      {"1x1 skip 96->64, 8x16x24", {1, 96, 64, 8, 16, 24, 1}},
  };
  if (!quick) {
    cases.push_back({"C64->64, 32^3", {1, 64, 64, 32, 32, 32, 3}});
    cases.push_back({"C192->192, 16^3", {1, 192, 192, 16, 16, 16, 3}});
    cases.push_back({"released L2 C768->768, 16^3", {1, 768, 768, 16, 16, 16, 3}});
  }
  if (released_levels) {
    cases.push_back({"released L1 C384->384, 32^3", {1, 384, 384, 32, 32, 32, 3}});
    cases.push_back({"released L0 C192->192, 64^3", {1, 192, 192, 64, 64, 64, 3}});
  }
  // The kernel variants side by side: path x weight precision (Conv3dPath; fp16 = packed fp16 weights).
  using Variant = bench::ConvVariant;
  std::vector<Variant> variants;
  try {
    variants = bench::conv_variants(conv_variants, ctx.info(), "--conv-paths");
  } catch (const std::invalid_argument& e) {
    std::fprintf(stderr, "icube-bench-nn: %s\n", e.what());
    return 2;
  }
  // "vs first": max |y - y_first| / max |y_first| against the first variant's output in the same run (the
  // check at shapes too large for the CPU reference).
  // "peak": the fraction of the device's fp16 tensor peak on the cooperative-matrix path, else of its fp32 peak.
  std::printf("%-30s %-14s %9s %10s %10s %9s %7s %12s %10s %10s %10s %10s %9s %10s\n", "conv3d", "path", "GFLOP", "gpu min",
              "gpu med", "GFLOP/s", "peak", "cpu ref ms", "max rel", "vs first", "torch min", "torch med", "GFLOP/s",
              "vs torch");
  kernels::nn::Conv3d conv(ctx);
  for (const Case& c : cases) {
    if (!only.empty() && std::string(c.what).find(only) == std::string::npos) continue;
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> u(-1.f, 1.f);
    const auto& shape = c.s;
    nn::CpuTensor x({shape.batch, shape.in_channels, shape.x, shape.y, shape.z});
    for (float& v : x.data) v = u(rng);
    const int64_t k = shape.kernel;
    nn::CpuTensor w({shape.out_channels, shape.in_channels, k, k, k});
    for (float& v : w.data) v = u(rng) * 0.1f;
    nn::CpuTensor b({shape.out_channels});
    for (float& v : b.data) v = u(rng);
    gpu::Buffer xb = gpu::upload_vector(ctx, x.data);
    gpu::Buffer wb32 = gpu::upload_vector(
        ctx, kernels::nn::pack_conv3d_weights(w.data, shape.out_channels, shape.in_channels, shape.kernel));
    gpu::Buffer wb16 = gpu::upload_vector(
        ctx, kernels::nn::pack_conv3d_weights_f16(w.data, shape.out_channels, shape.in_channels, shape.kernel));
    gpu::Buffer bb = gpu::upload_vector(ctx, b.data);
    const size_t ny = static_cast<size_t>(shape.batch) * shape.out_channels * shape.voxels();
    gpu::Buffer yb(ctx, ny * 4);
    const double gflop = static_cast<double>(shape.flops()) * 1e-9;
    // The references, once per shape: the CPU's (timed) and PyTorch's.
    std::string cpu_ms = "-";
    std::vector<float> want;
    if (gflop <= cpu_limit_gflop) {
      const auto t0 = Clock::now();
      want = nn::cpu::conv3d(x, w, &b, 1, static_cast<int>(k / 2)).data;
      cpu_ms = std::to_string(static_cast<int>(ms_since(t0)));
    }
    TorchSide::Result tr;
    if (!torch_side.python.empty()) {
      tr = torch_side.run({{"op", "conv3d"}}, {{"x", &x}, {"w", &w}, {"b", &b}});
      if (!tr.ok) {
        std::fprintf(stderr, "icube-bench-nn: torch side failed: %s\n", tr.error.c_str());
        return 1;
      }
    }
    std::vector<float> first;
    for (const Variant& var : variants) {
      kernels::nn::Conv3dShape s = shape;
      s.f16_weights = var.f16;
      conv.force_path(var.path);
      std::vector<double> samples;
      for (int r = 0; r < warmup + runs; ++r) {
        const auto t0 = Clock::now();
        ctx.submit_and_wait([&](gpu::CommandList& cmd) { conv.record(cmd, s, xb, var.f16 ? wb16 : wb32, &bb, yb); });
        if (r >= warmup) samples.push_back(ms_since(t0));
      }
      const Stats st = stats(samples);
      const std::vector<float> got = gpu::download_vector<float>(ctx, yb, ny);
      char rel[32] = "-", vs_first[32] = "-";
      if (!want.empty()) std::snprintf(rel, sizeof rel, "%.1e", max_rel(got, want));
      if (first.empty()) first = got;
      else std::snprintf(vs_first, sizeof vs_first, "%.1e", max_rel(got, first));
      char t_min[32] = "-", t_med[32] = "-", t_rate[32] = "-", t_rel[32] = "-";
      if (tr.ok) {
        std::snprintf(t_min, sizeof t_min, "%.2f", tr.min_ms);
        std::snprintf(t_med, sizeof t_med, "%.2f", tr.median_ms);
        std::snprintf(t_rate, sizeof t_rate, "%.1f", gflop / (tr.min_ms * 1e-3));
        std::snprintf(t_rel, sizeof t_rel, "%.1e", max_rel(got, tr.y));
      }
      const double rate = gflop / (st.min * 1e-3);
      const std::string of = bench::percent_of_compute_peak(peak, rate, var.path == kernels::nn::Conv3dPath::kCoopMatrix);
      std::printf("%-30s %-14s %9.2f %10.2f %10.2f %9.2f %7s %12s %10s %10s %10s %10s %9s %10s\n", c.what,
                  var.name.c_str(), gflop, st.min, st.median, rate, of.c_str(), cpu_ms.c_str(), rel, vs_first, t_min, t_med,
                  t_rate, t_rel);
      std::fflush(stdout);
    }
  }
  conv.force_path(std::nullopt);
  return 0;
}

int NnBench::group_norm_table() {
  gpu::Context& ctx = *ctx_ptr;
  std::printf("\n%-30s %9s %10s %10s %9s %7s %12s %10s%s\n", "group_norm+ss+silu", "MB", "gpu min", "gpu med", "GB/s",
              "peak", "cpu ref ms", "max abs", torch_side.python.empty() ? "" : "  torch min  torch med      GB/s   vs torch");
  struct GnCase {
    const char* what;
    kernels::nn::GroupNormShape s;
  };
  std::vector<GnCase> gcases = {{"unet_small L0 32ch, 8x16x24", {1, 32, 32, 8 * 16 * 24, 1e-5f, true, true}},
                                {"C64, 32^3", {1, 64, 32, 32 * 32 * 32, 1e-5f, true, true}}};
  if (!quick) gcases.push_back({"released L0 C192, 64^3 / 2", {1, 96, 32, 64 * 64 * 64, 1e-5f, true, true}});
  kernels::nn::GroupNorm gn(ctx);
  for (const GnCase& c : gcases) {
    if (!only.empty() && std::string(c.what).find(only) == std::string::npos) continue;
    const auto& s = c.s;
    std::mt19937 rng(3);
    std::uniform_real_distribution<float> u(-1.f, 1.f);
    nn::CpuTensor x({s.batch, s.channels, static_cast<int64_t>(s.spatial)});
    for (float& v : x.data) v = u(rng);
    nn::CpuTensor w({s.channels}, 1.0f), b({s.channels}, 0.0f), mod({s.batch, 2 * static_cast<int64_t>(s.channels)});
    for (float& v : mod.data) v = 0.1f * u(rng);
    gpu::Buffer xb = gpu::upload_vector(ctx, x.data), wb = gpu::upload_vector(ctx, w.data),
                bb = gpu::upload_vector(ctx, b.data), mb = gpu::upload_vector(ctx, mod.data);
    gpu::Buffer scratch(ctx, kernels::nn::GroupNorm::scratch_bytes(s)), yb(ctx, x.data.size() * 4);
    auto time_gn = [&](const kernels::nn::GroupNormShape& shape) {
      std::vector<double> samples;
      for (int r = 0; r < warmup + runs; ++r) {
        const auto t0 = Clock::now();
        ctx.submit_and_wait([&](gpu::CommandList& cmd) { gn.record(cmd, shape, xb, wb, bb, &mb, scratch, yb); });
        if (r >= warmup) samples.push_back(ms_since(t0));
      }
      return stats(samples);
    };
    const Stats st = time_gn(s);
    const double mb_moved = static_cast<double>(x.data.size()) * 4 * 3 * 1e-6;  // read twice, write once
    const auto t0 = Clock::now();
    const nn::CpuTensor want =
        nn::cpu::silu(nn::cpu::scale_shift(nn::cpu::group_norm(x, static_cast<int>(s.groups), w, b, 1e-5), mod));
    const double cpu = ms_since(t0);
    const std::vector<float> got = gpu::download_vector<float>(ctx, yb, x.data.size());
    // The same with its output stored as fp16 (NetworkPrecision::F16: the next convolution's operand).
    kernels::nn::GroupNormShape s16 = s;
    s16.f16_output = true;
    const Stats st16 = time_gn(s16);
    const std::vector<uint16_t> got16 = gpu::download_vector<uint16_t>(ctx, yb, x.data.size());
    double mx16 = 0;
    for (size_t i = 0; i < got16.size(); ++i)
      mx16 = std::max(mx16, std::abs(static_cast<double>(nn::half_to_float(got16[i])) - static_cast<double>(want.data[i])));
    const double mb_moved16 = static_cast<double>(x.data.size()) * (4 * 2 + 2) * 1e-6;
    double mx = 0;
    for (size_t i = 0; i < got.size(); ++i) mx = std::max(mx, std::abs(static_cast<double>(got[i]) - static_cast<double>(want.data[i])));
    std::string torch_cols;
    if (!torch_side.python.empty()) {
      const TorchSide::Result tr = torch_side.run(
          {{"op", "group_norm"}, {"groups", s.groups}, {"eps", 1e-5}}, {{"x", &x}, {"mod", &mod}});
      if (!tr.ok) {
        std::fprintf(stderr, "icube-bench-nn: torch side failed: %s\n", tr.error.c_str());
        return 1;
      }
      char buf[96];
      std::snprintf(buf, sizeof buf, " %10.2f %10.2f %9.2f %10.1e", tr.min_ms, tr.median_ms,
                    mb_moved * 1e-3 / (tr.min_ms * 1e-3), max_rel(got, tr.y));
      torch_cols = buf;
    }
    // "peak": the fraction of the device's memory bandwidth.
    const double gbs = mb_moved * 1e-3 / (st.min * 1e-3), gbs16 = mb_moved16 * 1e-3 / (st16.min * 1e-3);
    std::printf("%-30s %9.1f %10.2f %10.2f %9.2f %7s %12.0f %10.1e%s\n", c.what, mb_moved, st.min, st.median, gbs,
                bench::percent_of_memory_peak(peak, gbs).c_str(), cpu, mx, torch_cols.c_str());
    std::printf("%-30s %9.1f %10.2f %10.2f %9.2f %7s %12s %10.1e\n", "  fp16 output", mb_moved16, st16.min, st16.median,
                gbs16, bench::percent_of_memory_peak(peak, gbs16).c_str(), "", mx16);
  }
  return 0;
}

int NnBench::attention_table() {
  gpu::Context& ctx = *ctx_ptr;
  std::printf("\n%-30s %-10s %9s %10s %10s %9s %7s %12s %10s%s\n", "attention", "path", "GFLOP", "gpu min", "gpu med",
              "GFLOP/s", "peak", "cpu ref ms", "max rel", torch_side.python.empty() ? "" : "  torch min  torch med   GFLOP/s   vs torch");
  struct AttnCase {
    const char* what;
    kernels::nn::AttentionShape s;
  };
  std::vector<AttnCase> acases = {{"unet_small L2 C64 h8, 384 tok", {1, 8, 8, 4 * 8 * 12}},
                                  {"C256 h8, 512 tokens", {1, 8, 32, 512}}};
  if (!quick) {
    acases.push_back({"released ds8 C768 h8, 8^3 tok", {1, 8, 96, 512}});
    acases.push_back({"released ds4 C768 h8, 16^3 tok", {1, 8, 96, 4096}});
  }
  kernels::nn::Attention attn(ctx);
  for (const AttnCase& c : acases) {
    if (!only.empty() && std::string(c.what).find(only) == std::string::npos) continue;
    const auto& s = c.s;
    std::mt19937 rng(11);
    std::normal_distribution<float> nd(0.0f, 1.0f);
    const int64_t C = static_cast<int64_t>(s.channels()), N = static_cast<int64_t>(s.tokens);
    nn::CpuTensor q({s.batch, C, N}), k({s.batch, C, N}), v({s.batch, C, N});
    for (nn::CpuTensor* t : {&q, &k, &v})
      for (float& f : t->data) f = nd(rng);
    gpu::Buffer qb = gpu::upload_vector(ctx, q.data), kb = gpu::upload_vector(ctx, k.data),
                vb = gpu::upload_vector(ctx, v.data), ob(ctx, q.data.size() * 4);
    const double gflop = 4.0 * s.batch * s.heads * static_cast<double>(N) * static_cast<double>(N) * s.head_dim * 1e-9;
    // CPU reference on [B, H, N, D].
    auto heads_last = [&](const nn::CpuTensor& t) {
      nn::CpuTensor o({s.batch, s.heads, N, s.head_dim});
      for (int64_t b = 0; b < s.batch; ++b)
        for (int64_t h = 0; h < s.heads; ++h)
          for (int64_t n = 0; n < N; ++n)
            for (int64_t d = 0; d < s.head_dim; ++d)
              o.data[static_cast<size_t>(((b * s.heads + h) * N + n) * s.head_dim + d)] =
                  t.data[static_cast<size_t>((b * C + h * s.head_dim + d) * N + n)];
      return o;
    };
    std::string cpu_ms = "-";
    std::vector<float> want;
    if (gflop <= cpu_limit_gflop) {
      const auto t0 = Clock::now();
      const nn::CpuTensor o = nn::cpu::attention(heads_last(q), heads_last(k), heads_last(v));
      cpu_ms = std::to_string(static_cast<int>(ms_since(t0)));
      want.resize(q.data.size());
      for (int64_t b = 0; b < s.batch; ++b)
        for (int64_t h = 0; h < s.heads; ++h)
          for (int64_t n = 0; n < N; ++n)
            for (int64_t d = 0; d < s.head_dim; ++d)
              want[static_cast<size_t>((b * C + h * s.head_dim + d) * N + n)] =
                  o.data[static_cast<size_t>(((b * s.heads + h) * N + n) * s.head_dim + d)];
    }
    TorchSide::Result tr;
    if (!torch_side.python.empty()) {
      tr = torch_side.run({{"op", "attention"}, {"heads", s.heads}}, {{"q", &q}, {"k", &k}, {"v", &v}});
      if (!tr.ok) {
        std::fprintf(stderr, "icube-bench-nn: torch side failed: %s\n", tr.error.c_str());
        return 1;
      }
    }
    // Both kernels side by side (a CPU device refuses the tiled kernel past its loop budget: named).
    for (const auto& [name, path] : {std::pair{"per-query", kernels::nn::AttentionPath::kPerQuery},
                                     std::pair{"tiled", kernels::nn::AttentionPath::kTiled}}) {
      attn.force_path(path);
      std::vector<double> samples;
      try {
        for (int r = 0; r < warmup + runs; ++r) {
          const auto t0 = Clock::now();
          ctx.submit_and_wait([&](gpu::CommandList& cmd) { attn.record(cmd, s, qb, kb, vb, ob); });
          if (r >= warmup) samples.push_back(ms_since(t0));
        }
      } catch (const std::invalid_argument& e) {
        std::printf("%-30s %-10s skipped: %s\n", c.what, name, e.what());
        continue;
      }
      const Stats st = stats(samples);
      const std::vector<float> got = gpu::download_vector<float>(ctx, ob, q.data.size());
      char rel[32] = "-";
      if (!want.empty()) std::snprintf(rel, sizeof rel, "%.1e", max_rel(got, want));
      char torch_cols[96] = "";
      if (tr.ok)
        std::snprintf(torch_cols, sizeof torch_cols, " %10.2f %10.2f %9.2f %10.1e", tr.min_ms, tr.median_ms,
                      gflop / (tr.min_ms * 1e-3), max_rel(got, tr.y));
      const double rate = gflop / (st.min * 1e-3);
      std::printf("%-30s %-10s %9.2f %10.2f %10.2f %9.2f %7s %12s %10s%s\n", c.what, name, gflop, st.min, st.median, rate,
                  bench::percent_of_compute_peak(peak, rate, false).c_str(), cpu_ms.c_str(), rel, torch_cols);
      std::fflush(stdout);
    }
  }
  attn.force_path(std::nullopt);
  return 0;
}

int NnBench::unet_case_run() {
  gpu::Context& ctx = *ctx_ptr;
  const std::string d = unet_case + "/";
  const nn::UNetConfig cfg = nn::load_unet_config(d + "config.json");
  const nn::UNetReference spec(cfg);
  const nn::SafetensorsFile file(d + "weights.safetensors");
  const auto w = nn::load_weights_cpu(file, spec.parameters(), {});
  const world::NpyArray xa = world::read_npy(d + "case_1.x.npy"), ta = world::read_npy(d + "case_1.t.npy"),
                        ya = world::read_npy(d + "case_1.out.npy");
  const nn::CpuTensor x(std::vector<int64_t>(xa.shape.begin(), xa.shape.end()), xa.values<float>());
  std::printf("\n%-28s %10s %10s %12s %16s\n", "unet_small case (official)", "gpu min", "gpu med", "weights MiB",
              "max|y-ref|/std");
  for (const auto& [name, prec] : {std::pair{"fp32", nn::UNetGpu::Precision::F32},
                                   std::pair{"fp16 weights", nn::UNetGpu::Precision::F16Weights},
                                   std::pair{"fp16 weights + operands", nn::UNetGpu::Precision::F16}}) {
    nn::UNetGpu net(ctx, cfg, w, prec);
    std::vector<double> samples;
    nn::CpuTensor y;
    for (int r = 0; r < warmup + runs; ++r) {
      const auto t0 = Clock::now();
      y = net.forward(x, ta.values<int64_t>());
      if (r >= warmup) samples.push_back(ms_since(t0));
    }
    const Stats st = stats(samples);
    std::printf("%-28s %10.1f %10.1f %12.2f %16.2e\n", name, st.min, st.median,
                static_cast<double>(net.weight_bytes()) / 1048576.0, nn::cpu::max_abs_over_std(y.data, ya.values<float>()));
  }
  if (!torch_side.python.empty()) {
    std::filesystem::create_directories(torch_side.dir);
    const TorchSide::Result tr = run_torch_unet(torch_side, d + "config.json", d + "weights.safetensors",
                                                d + "case_1.x.npy", d + "case_1.t.npy");
    if (!tr.ok) {
      std::fprintf(stderr, "icube-bench-nn: torch side failed: %s\n", tr.error.c_str());
      return 1;
    }
    std::printf("%-28s %10.1f %10.1f %12.2f %16.2e\n", "PyTorch (torch_unet.py)", tr.min_ms, tr.median_ms,
                static_cast<double>(file.data_bytes()) / 1048576.0, nn::cpu::max_abs_over_std(tr.y, ya.values<float>()));
  }
  return 0;
}

int NnBench::unet_forward_run() {
  gpu::Context& ctx = *ctx_ptr;
  const nn::UNetConfig cfg = nn::load_unet_config(unet_config);
  nn::UNetReference ref(cfg);
  std::fprintf(stderr, "icube-bench-nn: random weights for %s (%llu parameters)\n", unet_config.c_str(),
               static_cast<unsigned long long>(ref.parameter_count()));
  std::mt19937 rng(5);
  std::normal_distribution<float> nd(0.0f, 0.05f);
  std::map<std::string, nn::CpuTensor> w;
  for (const nn::ParamSpec& p : ref.parameters()) {
    nn::CpuTensor t(p.shape);
    for (float& f : t.data) f = nd(rng);
    w.emplace(p.name, std::move(t));
  }
  nn::UNetGpu net(ctx, cfg, w, nn::parse_network_precision(unet_precision));
  nn::CpuTensor x({unet_batch, cfg.in_channels, unet_grid[0], unet_grid[1], unet_grid[2]});
  for (float& f : x.data) f = nd(rng) * 20.0f;
  std::vector<double> samples;
  nn::CpuTensor y;
  for (int r = 0; r < warmup + runs; ++r) {
    const auto t0 = Clock::now();
    y = net.forward(x, std::vector<int64_t>(static_cast<size_t>(unet_batch), 500));
    if (r >= warmup) samples.push_back(ms_since(t0));
  }
  const Stats st = stats(samples);
  double cpu = -1, agreement = -1;
  if (!unet_no_cpu) {
    ref.set_weights(w);
    const auto t0 = Clock::now();
    const nn::CpuTensor want = ref.forward(x, std::vector<int64_t>(static_cast<size_t>(unet_batch), 500));
    cpu = ms_since(t0);
    agreement = nn::cpu::max_abs_over_std(y.data, want.data);
  }
  std::string torch_text;
  if (!torch_side.python.empty()) {
    std::filesystem::create_directories(torch_side.dir);
    std::vector<nn::TensorToWrite> tw;
    for (const nn::ParamSpec& p : ref.parameters()) tw.push_back(nn::f32_tensor(p.name, p.shape, w.at(p.name).data));
    const std::string wpath = (torch_side.dir / "unet_w.safetensors").string(), xpath = (torch_side.dir / "unet_x.npy").string(),
                      tpath = (torch_side.dir / "unet_t.npy").string();
    nn::write_safetensors(wpath, tw);
    tw.clear();
    bench::save_npy(xpath, x);
    world::write_npy(tpath, world::NpyArray::make<int64_t>({static_cast<uint64_t>(unet_batch)},
                                                           std::vector<int64_t>(static_cast<size_t>(unet_batch), 500)));
    const TorchSide::Result tr = run_torch_unet(torch_side, unet_config, wpath, xpath, tpath);
    std::filesystem::remove(wpath);
    if (!tr.ok) {
      std::fprintf(stderr, "icube-bench-nn: torch side failed: %s\n", tr.error.c_str());
      return 1;
    }
    char buf[160];
    std::snprintf(buf, sizeof buf, "; PyTorch min %.1f ms, median %.1f ms, max |gpu - torch| / std %.1e", tr.min_ms,
                  tr.median_ms, nn::cpu::max_abs_over_std(y.data, tr.y));
    torch_text = buf;
  }
  bool finite = true;
  for (const float f : y.data) finite = finite && std::isfinite(f);
  std::printf("\nUNet forward (%s, %llu parameters, %s, batch %lld, grid %lldx%lldx%lld): gpu min %.1f ms, median %.1f ms "
              "(activation pool peak %.1f MiB, weights %.1f MiB, output %s); CPU reference %.0f ms; "
              "max |gpu - cpu| / std %.1e\n",
              unet_config.c_str(), static_cast<unsigned long long>(ref.parameter_count()), unet_precision.c_str(),
              static_cast<long long>(unet_batch), static_cast<long long>(unet_grid[0]), static_cast<long long>(unet_grid[1]),
              static_cast<long long>(unet_grid[2]), st.min, st.median,
              static_cast<double>(net.last_activation_bytes()) / 1048576.0,
              static_cast<double>(net.weight_bytes()) / 1048576.0, finite ? "finite" : "NOT FINITE", cpu, agreement);
  // The convolutions', linears' and attention's FLOPs (the recorder's count) over the fastest forward, and that
  // rate's fraction of the device's peak for the arithmetic the default path uses (tensor cores with fp16 weights
  // where the device has them).
  const double gflop = static_cast<double>(net.last_matmul_flops()) * 1e-9;
  const bool tensor = kernels::nn::default_conv3d_path(ctx.info(), unet_precision != "fp32") ==
                      kernels::nn::Conv3dPath::kCoopMatrix;
  const double rate = gflop / (st.min * 1e-3);
  std::printf("  %.1f GFLOP in convolutions, linears and attention: %.1f GFLOP/s, %s of the device's %s peak\n", gflop, rate,
              bench::percent_of_compute_peak(peak, rate, tensor).c_str(), tensor ? "fp16 tensor" : "fp32");
  if (!torch_text.empty()) std::printf("  %s\n", torch_text.c_str() + 2);
  return 0;
}

int main(int argc, char** argv) {
  NnBench b;
  CLI::App app("icube-bench-nn: network kernels and the UNet on the GPU against their CPU references and PyTorch");
  app.add_option("--runs", b.runs, "Timed runs per shape (min 5 for the tables)")->capture_default_str();
  app.add_option("--warmup", b.warmup, "Untimed runs first")->capture_default_str();
  app.add_option("--cpu-limit", b.cpu_limit_gflop, "Run the CPU reference only on shapes up to this many GFLOP")
      ->capture_default_str();
  app.add_flag("--quick", b.quick, "Only the small shapes");
  app.add_option("--only", b.only, "Only the rows whose name contains this text");
  app.add_flag("--released-levels", b.released_levels,
               "Also conv3d at the released model's level shapes (64^3 x 192, 32^3 x 384, 16^3 x 768: "
               "130-520 GFLOP each, minutes per run on lavapipe)");
  app.add_option("--conv-paths", b.conv_variants,
                 "conv3d kernels side by side: register, tiled, coopmat, emulated, each optionally -fp16 (fp16 "
                 "weights; coopmat's operands are fp16 either way); coopmat is skipped on devices without it")
      ->delimiter(',')
      ->capture_default_str();
  app.add_flag("--torch", b.with_torch,
               "Also run PyTorch's CPU ops (bench/torch_nn.py, Debian python3-torch) on the same tensors, "
               "torch threads = LP_NUM_THREADS");
  app.add_option("--unet", b.unet_config, "Also time one whole UNet forward of this config JSON (random weights)")
      ->type_name("CONFIG");
  app.add_option("--unet-case", b.unet_case,
                 "Time the official reference case in this folder (models/unet_small) with fp32 and fp16 weights: "
                 "error against its output vs run time")
      ->type_name("DIR");
  app.add_flag("--unet-no-cpu", b.unet_no_cpu, "Skip the CPU reference of the --unet forward (hours at the released size)");
  app.add_option("--unet-precision", b.unet_precision,
                 std::string("The --unet forward's precision: ") + nn::network_precision_help())
      ->check(CLI::IsMember({"fp32", "fp16-weights", "fp16"}))
      ->capture_default_str();
  app.add_option("--unet-grid", b.unet_grid, "Grid of the UNet forward")->expected(3)->capture_default_str();
  app.add_option("--unet-batch", b.unet_batch, "Batch of the UNet forward (2: a guided sampling step)")
      ->check(CLI::Range(int64_t{1}, int64_t{8}))
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);

  gpu::Context ctx(gpu::ContextOptions::from_env());
  b.ctx_ptr = &ctx;
  std::printf("device: %s\n", ctx.info().name.c_str());
  b.peak = bench::device_peak(ctx.info().name);
  std::printf("%s\n", bench::device_peak_line(ctx.info().name).c_str());
  if (b.with_torch) {
    b.torch_side.python = python_with_torch();
    if (b.torch_side.python.empty()) {
      std::fprintf(stderr, "icube-bench-nn: --torch needs python3 with torch and numpy (apt install python3-torch)\n");
      return 2;
    }
    const char* lp = std::getenv("LP_NUM_THREADS");
    b.torch_side.threads = lp ? std::max(1, std::atoi(lp)) : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
    b.torch_side.runs = b.runs;
    b.torch_side.warmup = b.warmup;
    b.torch_side.dir = std::filesystem::temp_directory_path() / ("icube-bench-nn-" + std::to_string(getpid()));
    std::printf("PyTorch side: %d threads (LP_NUM_THREADS%s)\n", b.torch_side.threads, lp ? "" : " unset: all cores");
  }
  for (int (NnBench::*table)() : {&NnBench::conv3d_table, &NnBench::group_norm_table, &NnBench::attention_table})
    if (const int rc = (b.*table)()) return rc;
  if (!b.unet_case.empty())
    if (const int rc = b.unet_case_run()) return rc;
  if (!b.unet_config.empty()) return b.unet_forward_run();
  return 0;
}

// icube-bench-nn: the network layer's kernels against their CPU references,
// side by side in one run: conv3d (dense NCDHW, 3x3x3 and 1x1) and GroupNorm
// (+ scale-shift + SiLU) at the diffusion UNet's level shapes. GPU time per
// record (submit + wait, after a warm-up), GFLOP/s or GB/s, the plain CPU
// reference (double accumulation, one thread) where it finishes in seconds,
// and the max relative difference between them in the same run. See bench/README.md.
#include "gpu/context.h"
#include "nn/conv3d.h"
#include "nn/group_norm.h"
#include "nn/unet_config.h"
#include "nn/unet_gpu.h"
#include "nn/unet_reference.h"
#include "nn/layers_cpu.h"

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

}  // namespace

int main(int argc, char** argv) {
  CLI::App app("icube-bench-nn: network kernels (conv3d) on the GPU against their CPU references");
  int runs = 5, warmup = 1;
  double cpu_limit_gflop = 3.0;
  bool quick = false;
  std::string unet_config;
  std::vector<int64_t> unet_grid{8, 16, 24};
  app.add_option("--runs", runs, "Timed runs per shape (min 5 for the tables)")->capture_default_str();
  app.add_option("--warmup", warmup, "Untimed runs first")->capture_default_str();
  app.add_option("--cpu-limit", cpu_limit_gflop, "Run the CPU reference only on shapes up to this many GFLOP")
      ->capture_default_str();
  app.add_flag("--quick", quick, "Only the small shapes");
  app.add_option("--unet", unet_config, "Also time one whole UNet forward of this config JSON (random weights)")
      ->type_name("CONFIG");
  app.add_option("--unet-grid", unet_grid, "Grid of the UNet forward")->expected(3)->capture_default_str();
  CLI11_PARSE(app, argc, argv);

  gpu::Context ctx(gpu::ContextOptions::from_env());
  std::printf("device: %s\n", ctx.info().name.c_str());
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
  std::printf("%-30s %9s %10s %10s %9s %12s %10s\n", "conv3d", "GFLOP", "gpu min", "gpu med", "GFLOP/s", "cpu ref ms",
              "max rel");
  kernels::nn::Conv3d conv(ctx);
  for (const Case& c : cases) {
    const auto& s = c.s;
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> u(-1.f, 1.f);
    nn::CpuTensor x({s.batch, s.in_channels, s.x, s.y, s.z});
    for (float& v : x.data) v = u(rng);
    const int64_t k = s.kernel;
    nn::CpuTensor w({s.out_channels, s.in_channels, k, k, k});
    for (float& v : w.data) v = u(rng) * 0.1f;
    nn::CpuTensor b({s.out_channels});
    for (float& v : b.data) v = u(rng);
    gpu::Buffer xb = gpu::upload_vector(ctx, x.data);
    gpu::Buffer wb = gpu::upload_vector(ctx, kernels::nn::pack_conv3d_weights(w.data, s.out_channels, s.in_channels, s.kernel));
    gpu::Buffer bb = gpu::upload_vector(ctx, b.data);
    const size_t ny = static_cast<size_t>(s.batch) * s.out_channels * s.voxels();
    gpu::Buffer yb(ctx, ny * 4);
    std::vector<double> samples;
    for (int r = 0; r < warmup + runs; ++r) {
      const auto t0 = Clock::now();
      ctx.submit_and_wait([&](gpu::CommandList& cmd) { conv.record(cmd, s, xb, wb, &bb, yb); });
      if (r >= warmup) samples.push_back(ms_since(t0));
    }
    const Stats st = stats(samples);
    const double gflop = static_cast<double>(s.flops()) * 1e-9;
    std::string cpu_ms = "-", rel = "-";
    if (gflop <= cpu_limit_gflop) {
      const auto t0 = Clock::now();
      const nn::CpuTensor want = nn::cpu::conv3d(x, w, &b, 1, static_cast<int>(k / 2));
      cpu_ms = std::to_string(static_cast<int>(ms_since(t0)));
      const std::vector<float> got = gpu::download_vector<float>(ctx, yb, ny);
      double mx = 0, ref = 0;
      for (size_t i = 0; i < ny; ++i) {
        mx = std::max(mx, std::abs(static_cast<double>(got[i]) - static_cast<double>(want.data[i])));
        ref = std::max(ref, std::abs(static_cast<double>(want.data[i])));
      }
      char buf[32];
      std::snprintf(buf, sizeof buf, "%.1e", mx / std::max(ref, 1e-30));
      rel = buf;
    }
    std::printf("%-30s %9.2f %10.2f %10.2f %9.2f %12s %10s\n", c.what, gflop, st.min, st.median, gflop / (st.min * 1e-3),
                cpu_ms.c_str(), rel.c_str());
  }

  std::printf("\n%-30s %9s %10s %10s %9s %12s %10s\n", "group_norm+ss+silu", "MB", "gpu min", "gpu med", "GB/s",
              "cpu ref ms", "max abs");
  struct GnCase {
    const char* what;
    kernels::nn::GroupNormShape s;
  };
  std::vector<GnCase> gcases = {{"unet_small L0 32ch, 8x16x24", {1, 32, 32, 8 * 16 * 24, 1e-5f, true, true}},
                                {"C64, 32^3", {1, 64, 32, 32 * 32 * 32, 1e-5f, true, true}}};
  if (!quick) gcases.push_back({"released L0 C192, 64^3 / 2", {1, 96, 32, 64 * 64 * 64, 1e-5f, true, true}});
  kernels::nn::GroupNorm gn(ctx);
  for (const GnCase& c : gcases) {
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
    std::vector<double> samples;
    for (int r = 0; r < warmup + runs; ++r) {
      const auto t0 = Clock::now();
      ctx.submit_and_wait([&](gpu::CommandList& cmd) { gn.record(cmd, s, xb, wb, bb, &mb, scratch, yb); });
      if (r >= warmup) samples.push_back(ms_since(t0));
    }
    const Stats st = stats(samples);
    const double mb_moved = static_cast<double>(x.data.size()) * 4 * 3 * 1e-6;  // read twice, write once
    const auto t0 = Clock::now();
    const nn::CpuTensor want =
        nn::cpu::silu(nn::cpu::scale_shift(nn::cpu::group_norm(x, static_cast<int>(s.groups), w, b, 1e-5), mod));
    const double cpu = ms_since(t0);
    const std::vector<float> got = gpu::download_vector<float>(ctx, yb, x.data.size());
    double mx = 0;
    for (size_t i = 0; i < got.size(); ++i) mx = std::max(mx, std::abs(static_cast<double>(got[i]) - static_cast<double>(want.data[i])));
    std::printf("%-30s %9.1f %10.2f %10.2f %9.2f %12.0f %10.1e\n", c.what, mb_moved, st.min, st.median,
                mb_moved * 1e-3 / (st.min * 1e-3), cpu, mx);
  }

  if (!unet_config.empty()) {
    const nn::UNetConfig cfg = nn::load_unet_config(unet_config);
    nn::UNetReference ref(cfg);
    std::mt19937 rng(5);
    std::normal_distribution<float> nd(0.0f, 0.05f);
    std::map<std::string, nn::CpuTensor> w;
    for (const nn::ParamSpec& p : ref.parameters()) {
      nn::CpuTensor t(p.shape);
      for (float& f : t.data) f = nd(rng);
      w.emplace(p.name, std::move(t));
    }
    nn::UNetGpu net(ctx, cfg, w);
    nn::CpuTensor x({1, cfg.in_channels, unet_grid[0], unet_grid[1], unet_grid[2]});
    for (float& f : x.data) f = nd(rng) * 20.0f;
    std::vector<double> samples;
    nn::CpuTensor y;
    for (int r = 0; r < warmup + runs; ++r) {
      const auto t0 = Clock::now();
      y = net.forward(x, {500});
      if (r >= warmup) samples.push_back(ms_since(t0));
    }
    const Stats st = stats(samples);
    ref.set_weights(std::move(w));
    const auto t0 = Clock::now();
    const nn::CpuTensor want = ref.forward(x, {500});
    const double cpu = ms_since(t0);
    const double agreement = nn::cpu::max_abs_over_std(y.data, want.data);
    std::printf("\nUNet forward (%s, %llu parameters, grid %lldx%lldx%lld): gpu min %.1f ms, median %.1f ms "
                "(activation pool peak %.1f MiB); CPU reference %.0f ms; max |gpu - cpu| / std %.1e\n",
                unet_config.c_str(), static_cast<unsigned long long>(ref.parameter_count()),
                static_cast<long long>(unet_grid[0]), static_cast<long long>(unet_grid[1]),
                static_cast<long long>(unet_grid[2]), st.min, st.median,
                static_cast<double>(net.last_activation_bytes()) / 1048576.0, cpu,
                agreement);
  }
  return 0;
}

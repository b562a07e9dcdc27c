// icube-bench-sparse: sparse voxel convolution (kernels/nn/sparse_conv.h) on
// real 0.2 m worlds — the demo world (trajectory mode) and the Waymo scenario
// world (blocks mode) built by the procedural prior — against our dense conv3d
// over the same box (GPU) and, with --torch, PyTorch's CPU conv3d on that box,
// side by side in one run with equal threads. The box is taken around the ego
// at the middle of its track (--box X Y Z voxels, default 128 x 128 x 64;
// 256 256 128 is a whole InfiniCube chunk). Reports the occupancy, the
// neighbour-map build time, each convolution's min / median time, effective
// GFLOP/s (useful FLOPs: 2 Ci Co per neighbour pair that exists) and, for the
// dense rows, the GFLOP/s of the whole box; checks the sparse output against the
// dense GPU conv at the active sites in the same run. See bench/README.md.
#include "bench_stats.h"
#include "conv_variants.h"
#include "device_peaks.h"
#include "gpu/context.h"
#include "kernels/nn/conv3d.h"
#include "kernels/nn/sparse_conv.h"
#include "nn/random_weights.h"
#include "kernels/nn/sparse_cpu.h"
#include "nn/vae_config.h"
#include "nn/vae_gpu.h"
#include "scene/scene_load.h"
#include "torch_side.h"
#include "world/demo_scene.h"
#include "world/procedural/procedural_prior.h"
#include "world/world_build.h"
#include "bench_worlds.h"

#include <CLI/CLI.hpp>

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <random>
#include <string>
#include <thread>
#include <vector>

using namespace icube;
using Clock = std::chrono::steady_clock;

namespace {

double ms_since(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

// Times `fn` (one submit_and_wait each): min and median of `runs` after `warmup`.
bench::Summary time_runs(int runs, int warmup, const std::function<void()>& fn) {
  for (int i = 0; i < warmup; ++i) fn();
  std::vector<double> ms;
  for (int i = 0; i < runs; ++i) {
    const Clock::time_point t0 = Clock::now();
    fn();
    ms.push_back(ms_since(t0));
  }
  return bench::summarize(ms);
}


// The world's voxels inside a box around the ego at the middle of its track: ijk relative to the box's
// low corner, brick order. The box reaches a quarter of its height below the ego and the rest above.
nn::SparseGrid box_around_ego(const world::VoxelGrid& w, const scene::Scene& sc, const nn::Ijk& box) {
  std::vector<glm::dvec3> ego;
  for (const scene::EgoPose& p : sc.ego)
    if (p.valid) ego.emplace_back(p.ego_to_world[3]);
  if (ego.empty()) throw std::runtime_error("the scene has no valid ego pose");
  const glm::ivec3 c = w.world_to_ijk(ego[ego.size() / 2]);
  const glm::ivec3 lo(c.x - box[0] / 2, c.y - box[1] / 2, c.z - box[2] / 4);
  nn::SparseGrid g;
  g.voxel_size = {w.voxel_size(), w.voxel_size(), w.voxel_size()};
  w.for_each_voxel([&](const glm::ivec3& ijk, const world::Voxel&) {
    const glm::ivec3 r = ijk - lo;
    if (r.x >= 0 && r.y >= 0 && r.z >= 0 && r.x < box[0] && r.y < box[1] && r.z < box[2]) g.ijk.push_back({r.x, r.y, r.z});
  });
  nn::sort_brick_order(g);
  return g;
}

// max |got - want| / max |want|.
double max_rel_diff(const std::vector<float>& got, const std::vector<float>& want) {
  double worst = 0.0, peak = 0.0;
  for (size_t i = 0; i < want.size(); ++i) {
    worst = std::max(worst, std::abs(double{got[i]} - double{want[i]}));
    peak = std::max(peak, std::abs(double{want[i]}));
  }
  return got.size() == want.size() ? worst / std::max(peak, 1e-30) : 1e30;
}

// Whether a kernel variant rounds weights or operands to fp16.
bool has_f16(const bench::ConvVariant& v) {
  return v.f16 || kernels::nn::conv3d_path_rounds_activations(v.path);
}

struct Options {
  int runs = 5, warmup = 1, dense_runs = 5;
  nn::Ijk box{128, 128, 64};
  std::vector<int> channels{64, 128};
  std::vector<bench::ConvVariant> sparse_paths;
  bench::TorchSide torch;
  const bench::DevicePeak* peak = nullptr;  // the device's published peaks, when known (device_peaks.h)
};


bool run_case(gpu::Context& ctx, const std::string& name, const nn::SparseGrid& g, const Options& o) {
  const uint32_t N = static_cast<uint32_t>(g.size());
  const uint64_t V = uint64_t{static_cast<uint32_t>(o.box[0])} * o.box[1] * o.box[2];
  std::printf("\n%s: box %d x %d x %d voxels (%.1f x %.1f x %.1f m), %u active, occupancy %.2f %%\n", name.c_str(), o.box[0],
              o.box[1], o.box[2], o.box[0] * g.voxel_size[0], o.box[1] * g.voxel_size[1], o.box[2] * g.voxel_size[2], N,
              100.0 * N / static_cast<double>(V));
  if (N == 0) return true;
  // Neighbour map on the GPU, timed from the uploaded coordinates.
  std::vector<int32_t> flat;
  for (const nn::Ijk& c : g.ijk) flat.insert(flat.end(), c.begin(), c.end());
  gpu::Buffer ijk = gpu::upload_vector(ctx, flat, "bench-ijk");
  const uint32_t ts = kernels::nn::SparseKernelMap::table_size(N);
  gpu::Buffer table(ctx, uint64_t{ts} * 4, gpu::MemoryUsage::DeviceLocal, "bench-table");
  gpu::Buffer kmap(ctx, uint64_t{N} * 27 * 4, gpu::MemoryUsage::DeviceLocal, "bench-kmap");
  kernels::nn::SparseKernelMap km(ctx);
  const bench::Summary tk = time_runs(o.runs, o.warmup, [&] {
    ctx.submit_and_wait([&](gpu::CommandList& cmd) {
      km.record_clear(cmd, table, ts);
      cmd.barrier(gpu::deps::kTransferToCompute);
      km.record_insert(cmd, N, ijk, table, ts);
      cmd.barrier(gpu::deps::kComputeToCompute);
      km.record_map(cmd, N, ijk, table, ts, kmap);
    });
  });
  const std::vector<int32_t> map = gpu::download_vector<int32_t>(ctx, kmap, uint64_t{N} * 27);
  const bool map_ok = map == nn::cpu::kernel_map(g, 3);
  const uint64_t pairs = static_cast<uint64_t>(std::count_if(map.begin(), map.end(), [](int32_t v) { return v >= 0; }));
  std::printf("kernel map: %.2f / %.2f ms (min / median), %.2f neighbours per voxel, %s against the CPU map\n", tk.min_ms,
              tk.median_ms, static_cast<double>(pairs) / N, map_ok ? "equal" : "DIFFERENT");
  // "peak": the dense rate's fraction of the device's fp32 peak, the sparse rows' useful rate's of the fp16
  // tensor peak on the cooperative-matrix path and of the fp32 peak elsewhere.
  std::printf("%-26s %8s %10s %10s %9s %11s %10s %9s %7s\n", "conv 3^3", "channels", "min ms", "median ms", "GFLOP/s",
              "useful GF/s", "memory MB", "max rel", "peak");
  bool ok = map_ok;
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  kernels::nn::SparseConv3d sconv(ctx);
  kernels::nn::Conv3d dconv(ctx);
  for (const int C : o.channels) {
    const uint32_t c = static_cast<uint32_t>(C);
    std::vector<float> xs(uint64_t{c} * N), w(uint64_t{c} * c * 27), b(c);
    for (float& v : xs) v = u(rng);
    for (float& v : w) v = 0.2f * u(rng);
    for (float& v : b) v = u(rng);
    const std::vector<float> packed = kernels::nn::pack_conv3d_weights(w, c, c, 3);
    gpu::Buffer xb = gpu::upload_vector(ctx, xs, "bench-x"), wb = gpu::upload_vector(ctx, packed, "bench-w"),
                wb16 = gpu::upload_vector(ctx, kernels::nn::pack_conv3d_weights_f16(w, c, c, 3), "bench-w16"),
                bb = gpu::upload_vector(ctx, b, "bench-b");
    gpu::Buffer yb(ctx, uint64_t{c} * N * 4, gpu::MemoryUsage::DeviceLocal, "bench-y");
    const double useful = 2.0 * c * c * static_cast<double>(pairs) * 1e-9;
    const double sparse_mb = (2.0 * c * N * 4 + N * 27.0 * 4) / 1e6;
    // The sparse kernels side by side (--sparse-paths; max rel against the first, which the dense rows check).
    std::vector<float> ys;
    double first_ms = 0.0;
    for (const bench::ConvVariant& var : o.sparse_paths) {
      const kernels::nn::SparseConvShape s{N, c, c, false, var.f16};
      sconv.force_path(var.path);
      const bench::Summary t = time_runs(o.runs, o.warmup, [&] {
        ctx.submit_and_wait([&](gpu::CommandList& cmd) { sconv.record(cmd, s, xb, kmap, var.f16 ? wb16 : wb, &bb, yb); });
      });
      std::vector<float> got = gpu::download_vector<float>(ctx, yb, uint64_t{c} * N);
      char rel[32] = "-";
      if (ys.empty()) {
        ys = std::move(got);
        first_ms = t.min_ms;
      } else {
        const double r = max_rel_diff(got, ys);
        // fp16 weights or operands round each term by up to 2^-11: a bound of 1e-2 of the largest output.
        ok = ok && r <= (has_f16(var) || has_f16(o.sparse_paths.front()) ? 1e-2 : 1e-5);
        std::snprintf(rel, sizeof rel, "%.1e", r);
      }
      const std::string label = "sparse " + var.name;
      const double rate = useful / (t.min_ms * 1e-3);
      std::printf("%-26s %8d %10.1f %10.1f %9.2f %11.2f %10.1f %9s %7s\n", label.c_str(), C, t.min_ms, t.median_ms, rate,
                  rate, sparse_mb, rel,
                  bench::percent_of_compute_peak(o.peak, rate, var.path == kernels::nn::Conv3dPath::kCoopMatrix).c_str());
    }
    sconv.force_path(std::nullopt);
    if (o.dense_runs < 1) continue;  // sparse only
    // Dense conv3d over the zero-filled box (NCDHW), the same weights (grid order = the dense kernel's).
    nn::CpuTensor xd({1, C, o.box[0], o.box[1], o.box[2]});
    for (uint32_t r = 0; r < N; ++r) {
      const nn::Ijk& q = g.ijk[r];
      const uint64_t v = (uint64_t{static_cast<uint32_t>(q[0])} * o.box[1] + q[1]) * o.box[2] + q[2];
      for (uint32_t ch = 0; ch < c; ++ch) xd.data[ch * V + v] = xs[uint64_t{ch} * N + r];
    }
    gpu::Buffer xdb = gpu::upload_vector(ctx, xd.data, "bench-xd");
    gpu::Buffer ydb(ctx, uint64_t{c} * V * 4, gpu::MemoryUsage::DeviceLocal, "bench-yd");
    const kernels::nn::Conv3dShape ds{1, c, c, static_cast<uint32_t>(o.box[0]), static_cast<uint32_t>(o.box[1]),
                                      static_cast<uint32_t>(o.box[2]), 3, false};
    const bench::Summary td = time_runs(o.dense_runs, std::min(o.warmup, 1), [&] {
      ctx.submit_and_wait([&](gpu::CommandList& cmd) { dconv.record(cmd, ds, xdb, wb, &bb, ydb); });
    });
    const std::vector<float> yd = gpu::download_vector<float>(ctx, ydb, uint64_t{c} * V);
    double worst = 0.0, peak = 0.0;
    for (uint32_t r = 0; r < N; ++r) {
      const nn::Ijk& q = g.ijk[r];
      const uint64_t v = (uint64_t{static_cast<uint32_t>(q[0])} * o.box[1] + q[1]) * o.box[2] + q[2];
      for (uint32_t ch = 0; ch < c; ++ch) {
        worst = std::max(worst, std::abs(double{ys[uint64_t{ch} * N + r]} - double{yd[ch * V + v]}));
        peak = std::max(peak, std::abs(double{yd[ch * V + v]}));
      }
    }
    const double rel = worst / std::max(peak, 1e-30);
    ok = ok && rel < (has_f16(o.sparse_paths.front()) ? 1e-2 : 1e-5);
    char relbuf[32];
    std::snprintf(relbuf, sizeof relbuf, "%.1e", rel);
    const double dense_gf = ds.flops() * 1e-9;
    std::printf("%-26s %8d %10.1f %10.1f %9.2f %11.2f %10.1f %9s %7s\n", "dense conv3d (GPU, box)", C, td.min_ms,
                td.median_ms, dense_gf / (td.min_ms * 1e-3), useful / (td.min_ms * 1e-3), 2.0 * c * V * 4 / 1e6, relbuf,
                bench::percent_of_compute_peak(o.peak, dense_gf / (td.min_ms * 1e-3), false).c_str());
    if (!o.torch.python.empty()) {
      nn::CpuTensor wt({C, C, 3, 3, 3}, w), bt({C}, b);
      const bench::TorchSide::Result tr = o.torch.run({{"op", "conv3d"}}, {{"x", &xd}, {"w", &wt}, {"b", &bt}});
      if (!tr.ok) {
        std::fprintf(stderr, "icube-bench-sparse: torch side failed: %s\n", tr.error.c_str());
        ok = false;
      } else {
        double tw = 0.0;
        for (uint32_t r = 0; r < N; ++r) {
          const nn::Ijk& q = g.ijk[r];
          const uint64_t v = (uint64_t{static_cast<uint32_t>(q[0])} * o.box[1] + q[1]) * o.box[2] + q[2];
          for (uint32_t ch = 0; ch < c; ++ch) tw = std::max(tw, std::abs(double{ys[uint64_t{ch} * N + r]} - double{tr.y[ch * V + v]}));
        }
        std::snprintf(relbuf, sizeof relbuf, "%.1e", tw / std::max(peak, 1e-30));
        std::printf("%-26s %8d %10.1f %10.1f %9.2f %11.2f %10.1f %9s\n", "PyTorch conv3d (CPU, box)", C, tr.min_ms, tr.median_ms,
                    dense_gf / (tr.min_ms * 1e-3), useful / (tr.min_ms * 1e-3), 2.0 * c * V * 4 / 1e6, relbuf);
      }
    }
    std::printf("%-26s %8d %9.1fx faster than the dense GPU conv over the box\n", "sparse speed-up", C, td.min_ms / first_ms);
  }
  return ok;
}

// One structure-VAE decode of a random latent on a dense box (random weights of `model`'s shapes): each
// stage's wall time and rows, the activation pool's peak and the weights' device memory.
bool run_vae_decode(gpu::Context& ctx, const std::string& model, const nn::Ijk& box, int runs, nn::NetworkPrecision precision) {
  const nn::VaeConfig cfg = nn::load_vae_config(model);
  std::printf("\nVAE decode (%s, random weights, %s), latent box %d x %d x %d x %d channels\n", model.c_str(),
              nn::network_precision_name(precision), box[0], box[1], box[2], cfg.latent_channels());
  nn::VaeGpu vae(ctx, cfg, nn::random_weights(nn::vae_param_specs(cfg, nn::VaePart::Decoder), 9), precision);
  nn::SparseTensor latent;
  std::array<double, 3> vs{0.2, 0.2, 0.2}, origin{};
  for (int l = 1; l < cfg.num_blocks; ++l)
    for (int d = 0; d < 3; ++d) vs[d] *= cfg.pool_factor(l)[d];
  for (int d = 0; d < 3; ++d) origin[d] = vs[d] / 2;
  latent.grid = nn::dense_box_grid({-box[0] / 2, -box[1] / 2, -box[2] / 2}, box, vs, origin);
  latent.channels = cfg.latent_channels();
  std::mt19937 rng(5);
  std::normal_distribution<float> n(0.0f, 1.0f);
  latent.data.resize(static_cast<size_t>(latent.rows() * latent.channels));
  for (float& v : latent.data) v = n(rng);
  std::vector<double> totals;
  for (int r = 0; r < runs; ++r) {
    const Clock::time_point t0 = Clock::now();
    const nn::VaeDecoded d = vae.decode(latent);
    totals.push_back(ms_since(t0));
    if (r + 1 == runs) {
      for (const nn::VaeGpu::Stage& st : vae.last_stages())
        std::printf("  %-48s %9u rows %10.1f ms\n", st.label.c_str(), st.rows, st.ms);
      std::printf("  output: %lld voxels at 0.2 m; levels (before pruning):", static_cast<long long>(d.semantic.rows()));
      for (size_t l = d.levels.size(); l-- > 0;) std::printf(" %lld", static_cast<long long>(d.levels[l].grid.size()));
      std::printf("\n");
    }
  }
  const bench::Summary s = bench::summarize(totals);
  std::printf("  decode: %.1f / %.1f ms (min / median of %d); activations %.1f MiB peak, weights %.1f MiB\n", s.min_ms, s.median_ms, runs,
              static_cast<double>(vae.last_activation_bytes()) / (1024.0 * 1024.0), static_cast<double>(vae.weight_bytes()) / (1024.0 * 1024.0));
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"icube-bench-sparse: sparse voxel convolution on real worlds against dense conv3d over the same box"};
  Options o;
  std::string which = "all";
  bool with_torch = false;
  std::vector<int> box{128, 128, 64};
  app.add_option("--runs", o.runs, "Timed runs (min 5 for the tables)");
  app.add_option("--warmup", o.warmup, "Untimed runs first");
  app.add_option("--dense-runs", o.dense_runs, "Timed runs of the dense convolutions (seconds to minutes each; 0: sparse only)");
  app.add_option("--box", box, "Box around the ego in voxels (X Y Z); 256 256 128 = a whole chunk")->expected(3);
  app.add_option("--channels", o.channels, "Channel counts (in = out)");
  std::vector<std::string> sparse_paths{"register", "tiled"};
  app.add_option("--sparse-paths", sparse_paths,
                 "Sparse kernels side by side: register, tiled, coopmat, emulated, each optionally -fp16 (fp16 weights; "
                 "coopmat's operands are fp16 either way); the first is checked against the dense conv, the others "
                 "against the first; coopmat is skipped on devices without it")
      ->delimiter(',')
      ->capture_default_str();
  app.add_option("--case", which, "all, demo or waymo")->check(CLI::IsMember({"all", "demo", "waymo"}));
  std::vector<int> vae_box;
  std::string vae_model = "infinicube-vae";
  app.add_option("--vae-decode", vae_box, "Only a structure-VAE decode of a random latent on this box (X Y Z latent voxels; 64 64 64 = a chunk)")
      ->expected(3);
  app.add_option("--vae-model", vae_model, "VAE config or preset for --vae-decode")->capture_default_str();
  std::string vae_precision = "fp32";
  app.add_option("--vae-precision", vae_precision, std::string("--vae-decode's precision: ") + nn::network_precision_help())
      ->check(CLI::IsMember({"fp32", "fp16-weights", "fp16"}))
      ->capture_default_str();
  app.add_flag("--torch", with_torch, "Also PyTorch's CPU conv3d on the box (Debian python3-torch), threads = LP_NUM_THREADS");
  CLI11_PARSE(app, argc, argv);
  o.box = {box[0], box[1], box[2]};
  if (with_torch) {
    o.torch.python = bench::python_with_torch();
    if (o.torch.python.empty()) {
      std::fprintf(stderr, "icube-bench-sparse: --torch needs python3 with torch and numpy (apt install python3-torch)\n");
      return 2;
    }
    const char* lp = std::getenv("LP_NUM_THREADS");
    o.torch.threads = lp ? std::max(1, std::atoi(lp)) : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
    o.torch.runs = o.dense_runs;
    o.torch.warmup = 1;
    o.torch.dir = std::filesystem::temp_directory_path() / ("icube-bench-sparse-" + std::to_string(getpid()));
  }
  gpu::Context ctx;
  std::printf("device: %s; LP_NUM_THREADS=%s\n", ctx.info().name.c_str(), std::getenv("LP_NUM_THREADS") ? std::getenv("LP_NUM_THREADS") : "unset");
  std::printf("%s\n", bench::device_peak_line(ctx.info().name).c_str());
  o.peak = bench::device_peak(ctx.info().name);
  if (!vae_box.empty())
    return run_vae_decode(ctx, vae_model, {vae_box[0], vae_box[1], vae_box[2]}, o.runs,
                          nn::parse_network_precision(vae_precision))
               ? 0
               : 1;
  try {
    o.sparse_paths = bench::conv_variants(sparse_paths, ctx.info(), "--sparse-paths");
  } catch (const std::invalid_argument& e) {
    std::fprintf(stderr, "icube-bench-sparse: %s\n", e.what());
    return 2;
  }
  if (o.sparse_paths.empty()) {
    std::fprintf(stderr, "icube-bench-sparse: --sparse-paths: no kernel this device runs\n");
    return 2;
  }
  bool ok = true;
  const char* data_env = std::getenv("ICUBE_TEST_DATA");
  const std::string data = data_env ? data_env : "../shared/data";
  if (which == "all" || which == "demo") {
    const scene::Scene sc = world::make_demo_scene();
    double s = 0.0;
    const world::VoxelGrid w = bench::build_procedural(sc, world::PlanMode::Trajectory, s);
    std::printf("\n(demo world built in %.1f s, not timed)\n", s);
    ok = run_case(ctx, "demo world (trajectory)", box_around_ego(w, sc, o.box), o) && ok;
  }
  if (which == "all" || which == "waymo") {
    const std::string path = data + "/maps/waymo/motion_data_one_scenario.tfrecord";
    if (!std::filesystem::exists(path)) {
      std::printf("\nskip waymo (blocks): %s not found (set ICUBE_TEST_DATA)\n", path.c_str());
    } else {
      const scene::Scene sc = scene::load_scene(path);
      double s = 0.0;
      const world::VoxelGrid w = bench::build_procedural(sc, world::PlanMode::Blocks, s);
      std::printf("\n(waymo world built in %.1f s, not timed)\n", s);
      ok = run_case(ctx, "waymo world (blocks)", box_around_ego(w, sc, o.box), o) && ok;
    }
  }
  if (!o.torch.python.empty()) std::filesystem::remove_all(o.torch.dir);
  return ok ? 0 : 1;
}

// icube-bench-gsm: the GSM (InfiniCube's stage-3 feed-forward reconstruction
// model) on the default device, in one run:
//   check     the GPU forward (nn::GsmGpu) against the CPU reference (gsm_forward_reference) on the same
//             synthetic street at reduced widths (gsm_small's: the released structure with narrow layers),
//             every output tensor (integers exactly, floats within 1e-4 of their std)
//   rays      the pixel rays at the released input size: the double reference on every core against the
//             ray caster with its marked rays re-marched in double, the same answer required
//   released  one forward of the released widths (the infinicube-gsm preset, seeded random weights) at the
//             released input size (480 x 832 front images) for each --views count: time per stage
//             (GsmGpu::last_stages), GFLOP and GFLOP/s per stage (gsm_flops.h), host peak RSS per stage
//             (sampled), device weights and activation pool; outputs checked finite
//   dav2      Depth-Anything-V2-Large on one image: the engine's GPU stage, optionally its CPU reference,
//             and PyTorch's CPU run of the same module (bench/dav2_torch.py, Debian python3-torch) on the
//             same weights (written as .safetensors) and input, with torch threads = LP_NUM_THREADS;
//             max |diff| / std between the outputs (bench/bench_gsm_dav2.cpp)
// The options and the run's state: bench/gsm_bench.h. The scene is bench/gsm_street_scene.h. See
// bench/README.md, "icube-bench-gsm".
#include "bench_host.h"
#include "gsm_bench.h"
#include "gsm_flops.h"
#include "gsm_street_scene.h"

#include "gpu/context.h"
#include "nn/gsm/gsm_gpu.h"
#include "nn/gsm/gsm_params.h"
#include "nn/gsm/gsm_preset.h"
#include "nn/gsm/gsm_random_weights.h"
#include "nn/gsm/gsm_rays.h"
#include "nn/gsm/gsm_rays_gpu.h"
#include "nn/safetensors.h"

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cinttypes>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

using namespace icube;
using namespace icube::bench;

namespace {




// ---- configurations --------------------------------------------------------------------------------

// The released configuration with gsm_small's widths (../shared/data/models/gsm_small/README.md "Reduced
// widths"): the same structure, block types, counts and thresholds, narrow layers.
nn::GsmModelConfig reduced_model() {
  nlohmann::json j = nn::read_gsm_config_json(nn::kInfinicubeGsmPreset).json;
  nlohmann::json& bb = j["dav2_config"]["backbone_config"];
  bb["hidden_size"] = 64;
  bb["num_attention_heads"] = 4;
  bb["num_hidden_layers"] = 4;
  bb["out_indices"] = {1, 2, 3, 4};
  nlohmann::json& dav2 = j["dav2_config"];
  dav2["fusion_hidden_size"] = 32;
  dav2["head_hidden_size"] = 8;
  dav2["neck_hidden_sizes"] = {16, 32, 64, 64};
  dav2["reassemble_hidden_size"] = 64;
  nlohmann::json& h = j["hparams"];
  nlohmann::json& unet2d = h["backbone"]["params"]["backbone_2d_params"]["unet2d_params"];
  unet2d["channels"] = 12;
  unet2d["dim"] = 8;
  unet2d["init_dim"] = 8;
  unet2d["out_dim"] = 12;
  nlohmann::json& b3 = h["backbone"]["params"]["backbone_3d_params"];
  b3["f_maps"] = 16;
  b3["f_maps_2d"] = 16;
  b3["in_channels"] = 16;
  b3["lifter_params"]["img_in_dim"] = 16;
  b3["lifter_params"]["voxel_out_dim"] = 16;
  h["encoder"]["conv_params"]["conv_encoder_out_dim"] = 16;
  h["encoder"]["conv_params"]["n_filter_list"] = {3, 8, 16, 16};
  h["encoder"]["dav2_params"]["out_dim_list"] = {16, 8};
  h["encoder"]["dav2_params"]["target_input_size"] = {56, 84};
  nlohmann::json& sky = h["skybox_mlp_modulator"];
  sky["embed_dim"] = 32;
  sky["hidden_channels"] = 32;
  sky["transformer"]["dim_feedforward"] = 64;
  sky["transformer"]["num_layers"] = 2;
  return nn::gsm_model_config_from_json(j, "infinicube-gsm at gsm_small's widths");
}

// ---- output comparison -----------------------------------------------------------------------------

struct Comparison {
  bool ok = true;
  double worst = 0;  // largest max |got - ref| / std(ref) over the float tensors
  std::string worst_name, failure;
};

Comparison compare_outputs(const nn::GsmOutputs& got, const nn::GsmOutputs& want, double tolerance) {
  Comparison c;
  const std::vector<nn::TensorToWrite> g = nn::gsm_output_tensors(got), w = nn::gsm_output_tensors(want);
  if (g.size() != w.size()) return {false, 0, "", "output tensor counts differ"};
  for (size_t i = 0; i < g.size(); ++i) {
    if (g[i].name != w[i].name || g[i].shape != w[i].shape) {
      c.ok = false;
      c.failure += g[i].name + ": shape " + nn::shape_text(g[i].shape) + " against " + nn::shape_text(w[i].shape) + "; ";
      continue;
    }
    if (g[i].dtype != nn::DType::F32) {
      if (g[i].bytes != w[i].bytes) {
        c.ok = false;
        c.failure += g[i].name + ": integers differ; ";
      }
      continue;
    }
    std::vector<float> a(g[i].bytes.size() / 4), b(w[i].bytes.size() / 4);
    if (a.empty()) continue;
    std::memcpy(a.data(), g[i].bytes.data(), g[i].bytes.size());
    std::memcpy(b.data(), w[i].bytes.data(), w[i].bytes.size());
    const double e = nn::cpu::max_abs_over_std(a, b);
    if (!(e <= tolerance)) {
      c.ok = false;
      c.failure += g[i].name + ": " + std::to_string(e) + " of std; ";
    }
    if (!(e <= c.worst)) {
      c.worst = e;
      c.worst_name = g[i].name;
    }
  }
  return c;
}

bool all_finite(const nn::GsmOutputs& out) {
  for (const nn::TensorToWrite& t : nn::gsm_output_tensors(out)) {
    if (t.dtype != nn::DType::F32) continue;
    const float* v = reinterpret_cast<const float*>(t.bytes.data());
    for (size_t i = 0; i < t.bytes.size() / 4; ++i)
      if (!std::isfinite(v[i])) return false;
  }
  return true;
}

int64_t voxel_gaussians(const nn::GsmOutputs& o) {
  int64_t n = 0;
  for (const nn::GsmElementOutputs& e : o.elements) n += e.voxel.count();
  return n;
}
int64_t pixel_gaussians(const nn::GsmOutputs& o) {
  int64_t n = 0;
  for (const nn::GsmElementOutputs& e : o.elements) n += e.pixel.count();
  return n;
}

// A stage's FLOPs by its GsmGpu label.
double stage_flops(const bench::GsmFlops& f, const std::string& label) {
  auto has = [&](const char* s) { return label.find(s) != std::string::npos; };
  if (has("image features")) return f.conv_encoder + f.dav2;
  if (has("sky token")) return f.sky_token;
  if (has("voxel branch")) return f.voxel_branch;
  if (has("pixel branch")) return f.pixel_branch;
  if (has("sky colours")) return f.sky_colours;
  return 0.0;  // the pixel rays: a DDA, no multiply-adds counted
}

}  // namespace

// ---- the benchmark ---------------------------------------------------------------------------------

namespace icube::bench {


// The FLOP model (gsm_flops.h) of the released widths at each view count, without running the network.
void GsmBench::flops_table(const nn::GsmModelConfig& model, const nn::GsmWeights& w) const {
  std::printf("\nFLOP model of the released widths (gsm_flops.h; GFLOP):\n");
  std::printf("%-6s %12s %12s %12s %12s %12s %12s\n", "views", "conv enc", "DAV2", "voxel br", "pixel br", "sky", "total");
  for (int64_t v : o.views) {
    const bench::GsmFlops f = bench::gsm_flops(model.config, w, bench::first_views(scene, v));
    std::printf("%-6lld %12.1f %12.1f %12.1f %12.1f %12.1f %12.1f\n", static_cast<long long>(v), f.conv_encoder * 1e-9,
                f.dav2 * 1e-9, f.voxel_branch * 1e-9, f.pixel_branch * 1e-9, (f.sky_token + f.sky_colours) * 1e-9,
                f.total() * 1e-9);
  }
  std::fflush(stdout);
}

void GsmBench::check_table() {
  const nn::GsmModelConfig model = reduced_model();
  const nn::GsmWeights w = nn::gsm_random_weights(nn::gsm_param_specs(model), o.seed);
  nn::GsmGpu gpu_gsm(*ctx, model.config, w);
  std::printf("\nCheck: GPU against the CPU reference, reduced widths (gsm_small's), %lld x %lld, the same street\n",
              static_cast<long long>(o.check_height), static_cast<long long>(o.check_width));
  std::printf("%-6s %12s %12s %10s %10s  %-44s %s\n", "views", "GPU s", "CPU ref s", "voxel GS", "pixel GS",
              "worst output (max |gpu - cpu| / std)", "check");
  for (int64_t v : o.views) {
    const nn::GsmInputs in = bench::first_views(check_scene, v);
    Clock::time_point t0 = Clock::now();
    nn::GsmOutputs got, want;
    try {
      got = gpu_gsm.forward(in);
    } catch (const std::exception& e) {
      std::printf("%-6lld GPU forward FAILED: %s\n", static_cast<long long>(v), e.what());
      failed = true;
      continue;
    }
    const double gpu_s = seconds_since(t0);
    t0 = Clock::now();
    want = nn::gsm_forward_reference(model.config, w, in, nullptr);
    const double cpu_s = seconds_since(t0);
    const Comparison c = compare_outputs(got, want, 1e-4);
    char worst[96];
    std::snprintf(worst, sizeof worst, "%s %.2e", c.worst_name.c_str(), c.worst);
    std::printf("%-6lld %12.2f %12.2f %10lld %10lld  %-44s %s\n", static_cast<long long>(v), gpu_s, cpu_s,
                static_cast<long long>(voxel_gaussians(got)), static_cast<long long>(pixel_gaussians(got)), worst,
                c.ok ? "ok" : "FAIL");
    if (!c.ok) {
      std::fprintf(stderr, "check failed at %lld views: %s\n", static_cast<long long>(v), c.failure.c_str());
      failed = true;
    }
    std::fflush(stdout);
  }
  std::printf("(GPU s: one forward, the first at each view count includes pipeline creation; CPU ref: one thread)\n");
}

// The pixel rays both ways at the released input size: the double reference on every core
// (cast_gsm_pixel_rays) and the engine's ray caster with the marked rays re-marched in double
// (cast_gsm_pixel_rays_gpu), the same answer required pixel for pixel.
void GsmBench::rays_table() {
  std::printf("\nPixel rays (first voxel, grid mask, voxel depth), %lld x %lld, the street's %zu voxels: host double on %u"
              " threads vs the ray caster (marked rays re-marched in double)\n",
              static_cast<long long>(o.height), static_cast<long long>(o.width), scene.voxel_ijk[0].size(),
              bench::online_cpus());
  std::printf("%-6s %-34s %10s %10s %10s %10s  %s\n", "views", "route", "min s", "median s", "Mrays/s", "re-checked",
              "check");
  for (int64_t v : o.views) {
    const nn::GsmInputs in = bench::first_views(scene, v);
    const double rays = static_cast<double>(v * o.height * o.width);
    std::vector<double> host_s, gpu_s;
    nn::GsmPixelRays want, got;
    nn::GsmRayCastStats stats;
    for (int r = 0; r < o.warmup + o.runs; ++r) {
      Clock::time_point t0 = Clock::now();
      want = nn::cast_gsm_pixel_rays(in, 0);
      if (r >= o.warmup) host_s.push_back(seconds_since(t0));
      stats = {};
      t0 = Clock::now();
      got = nn::cast_gsm_pixel_rays_gpu(*ctx, in, 0, &stats);
      if (r >= o.warmup) gpu_s.push_back(seconds_since(t0));
    }
    size_t bad = 0;
    for (size_t p = 0; p < want.first_voxel.size(); ++p)
      bad += got.first_voxel[p] != want.first_voxel[p] || got.grid_foreground[p] != want.grid_foreground[p] ||
             std::fabs(double(got.voxel_depth[p]) - double(want.voxel_depth[p])) >
                 2e-6 + 1e-6 * std::fabs(double(want.voxel_depth[p]));
    const MinMedian h = min_median(host_s), g = min_median(gpu_s);
    char marked[32];
    std::snprintf(marked, sizeof marked, "%.3f%%", 100.0 * static_cast<double>(stats.rechecked) / rays);
    std::printf("%-6lld %-34s %10.3f %10.3f %10.2f %10s  %s\n", static_cast<long long>(v), "host double (reference)", h.min,
                h.median, rays / h.min * 1e-6, "-", "ref");
    std::printf("%-6lld %-34s %10.3f %10.3f %10.2f %10s  %s\n", static_cast<long long>(v), "ray caster + double re-check",
                g.min, g.median, rays / g.min * 1e-6, marked, bad == 0 ? "ok" : "FAIL");
    std::printf("       (ray caster run: GPU part %.3f s, host re-check and row lookups %.3f s)\n", stats.gpu_ms * 1e-3,
                stats.host_ms * 1e-3);
    if (bad) {
      std::fprintf(stderr, "pixel rays differ at %zu pixels (%lld views)\n", bad, static_cast<long long>(v));
      failed = true;
    }
    std::fflush(stdout);
  }
  std::printf("(%d warm-up + %d timed runs each; a run includes the world and ray uploads)\n", o.warmup, o.runs);
}

void GsmBench::released_table(const nn::GsmModelConfig& model, const nn::GsmWeights& w) {
  Clock::time_point t0 = Clock::now();
  std::unique_ptr<nn::GsmGpu> gsm = std::make_unique<nn::GsmGpu>(*ctx, model.config, w);
  std::printf("\nReleased widths (infinicube-gsm, %.1f M parameters): weights uploaded in %.1f s, %.0f MiB on the device\n",
              static_cast<double>(nn::gsm_parameter_count(nn::gsm_param_specs(model))) * 1e-6, seconds_since(t0),
              mib(static_cast<double>(gsm->weight_bytes())));
  for (int64_t v : o.views) {
    const nn::GsmInputs in = bench::first_views(scene, v);
    const bool hwm_reset = reset_peak_rss();
    const long rss_before = rss_kib();
    std::vector<std::vector<double>> stage_s;  // per stage, per timed run
    std::vector<double> total_s;
    std::vector<long> stage_peak;
    std::vector<std::string> labels;
    std::vector<bool> on_device;
    nn::GsmOutputs out;
    std::string error;  // the exception that ended a forward, if one did
    DisturbanceMeter meter;
    for (int r = 0; r < o.warmup + o.runs && error.empty(); ++r) {
      const bool timed = r >= o.warmup;
      std::fprintf(stderr, "  released, %lld views: %s %d ...\n", static_cast<long long>(v), timed ? "run" : "warm-up",
                   timed ? r - o.warmup + 1 : r + 1);
      rss->clear();
      if (timed) meter.start();
      t0 = Clock::now();
      try {
        out = gsm->forward(in);
      } catch (const std::exception& e) {
        error = e.what();
      }
      const Clock::time_point t1 = Clock::now();
      if (timed) meter.stop();
      if (!timed && error.empty()) continue;
      // The stages that completed (all of them unless the forward threw), back to back up to t1.
      const std::vector<nn::GsmGpu::Stage>& stages = gsm->last_stages();
      for (size_t i = labels.size(); i < stages.size(); ++i) {
        labels.push_back(stages[i].label);
        on_device.push_back(stages[i].on_device);
        stage_s.emplace_back();
        stage_peak.push_back(0);
      }
      if (error.empty()) total_s.push_back(std::chrono::duration<double>(t1 - t0).count());
      // Stage intervals: anchored at the forward's end when it completed, else at its start.
      auto span = [](double ms) { return std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double, std::milli>(ms)); };
      Clock::duration before = Clock::duration::zero(), after = Clock::duration::zero();
      for (const nn::GsmGpu::Stage& st : stages) after += span(st.ms);
      for (size_t i = 0; i < stages.size(); ++i) {
        after -= span(stages[i].ms);
        const Clock::time_point begin = error.empty() ? t1 - after - span(stages[i].ms) : t0 + before;
        const Clock::time_point end = begin + span(stages[i].ms);
        before += span(stages[i].ms);
        stage_s[i].push_back(stages[i].ms * 1e-3);
        stage_peak[i] = std::max(stage_peak[i], rss->peak_kib(begin, end));
      }
    }
    const bool complete = error.empty();
    const bench::GsmFlops f = bench::gsm_flops(model.config, w, in);
    const int runs = static_cast<int>(stage_s.empty() ? 0 : stage_s.front().size());
    std::printf("\n%lld view%s of %lld x %lld, %zu voxels: ", static_cast<long long>(v), v > 1 ? "s" : "",
                static_cast<long long>(o.height), static_cast<long long>(o.width), in.voxel_ijk[0].size());
    if (complete)
      std::printf("%lld voxel + %lld pixel Gaussians, outputs %s; ", static_cast<long long>(voxel_gaussians(out)),
                  static_cast<long long>(pixel_gaussians(out)), all_finite(out) ? "finite" : "NOT FINITE");
    std::printf("%d run%s%s\n", runs, runs == 1 ? "" : "s",
                o.warmup ? (" after " + std::to_string(o.warmup) + " warm-up").c_str() : " (no warm-up: pipeline creation included)");
    if (!complete) {
      std::printf("FAILED after %zu stage%s: %s\n", labels.size(), labels.size() == 1 ? "" : "s", error.c_str());
      failed = true;
    } else if (!all_finite(out)) {
      failed = true;
    }
    std::printf("%-52s %-6s %9s %10s %10s %9s %12s\n", "stage", "where", "GFLOP", "min s", "median s", "GFLOP/s",
                "peak RSS MiB");
    for (size_t i = 0; i < labels.size(); ++i) {
      const MinMedian m = min_median(stage_s[i]);
      const double gf = stage_flops(f, labels[i]) * 1e-9;
      std::printf("%-52s %-6s %9.1f %10.2f %10.2f %9.1f %12.0f\n", labels[i].c_str(), on_device[i] ? "device" : "host", gf,
                  m.min, m.median, gf > 0 ? gf / m.min : 0.0, static_cast<double>(stage_peak[i]) / 1024.0);
    }
    if (complete) {
      const MinMedian m = min_median(total_s);
      std::printf("%-52s %-6s %9.1f %10.2f %10.2f %9.1f %12.0f\n", "whole forward", "", f.total() * 1e-9, m.min, m.median,
                  f.total() * 1e-9 / m.min, static_cast<double>(*std::max_element(stage_peak.begin(), stage_peak.end())) / 1024.0);
      std::printf("device memory: weights %.0f MiB + activation pool %.0f MiB (the forward's peak; the pool is shared by the stages)\n",
                  mib(static_cast<double>(gsm->weight_bytes())), mib(static_cast<double>(gsm->last_activation_bytes())));
    }
    std::printf("host: RSS %.0f MiB before the forwards, peak %s %.0f MiB; other processes took %.0f%% of the CPUs\n",
                static_cast<double>(rss_before) / 1024.0, hwm_reset ? "(VmHWM since then)" : "(VmHWM of the process)",
                static_cast<double>(status_kib("VmHWM")) / 1024.0, meter.percent());
    std::fflush(stdout);
  }
}

}  // namespace icube::bench

int main(int argc, char** argv) {
  Options o;
  std::string size_text = "480x832", check_size_text;
  bool no_check = false, no_rays = false, no_released = false, no_dav2 = false, no_torch = false;
  CLI::App app(
      "icube-bench-gsm: the GSM (stage-3 reconstruction) on the default device: GPU vs CPU reference at reduced widths, "
      "one forward of the released widths per view count (time, GFLOP/s and memory per stage), and Depth-Anything-V2-Large "
      "against PyTorch's CPU run of the same module. See bench/README.md.");
  app.add_option("--views", o.views, "Key frames (views) per forward, comma separated")->delimiter(',')->capture_default_str();
  app.add_option("--runs", o.runs, "Timed forwards of the released widths per view count")->capture_default_str();
  app.add_option("--warmup", o.warmup, "Untimed forwards first (0: the single run includes pipeline creation)")->capture_default_str();
  app.add_option("--size", size_text, "Input image size HxW (the release: 480x832 front images)")->capture_default_str();
  app.add_option("--check-size", check_size_text, "Image size HxW of the reduced-width check (default: half of --size)");
  app.add_option("--seed", o.seed, "Seed of the random weights and the depth-patch draw")->capture_default_str();
  app.add_flag("--flops", o.flops_only, "Only print the FLOP model of the released widths per view count (no forwards)");
  app.add_flag("--no-check", no_check, "Skip the GPU-vs-CPU-reference check at reduced widths");
  app.add_flag("--no-rays", no_rays, "Skip the pixel-ray table (host double vs the ray caster)");
  app.add_flag("--no-released", no_released, "Skip the released-width forwards");
  app.add_flag("--no-dav2", no_dav2, "Skip the Depth-Anything-V2 table");
  app.add_option("--dav2-runs", o.dav2_runs, "Timed Depth-Anything-V2 runs of the engine's GPU stage")->capture_default_str();
  app.add_option("--dav2-warmup", o.dav2_warmup, "Untimed Depth-Anything-V2 runs first")->capture_default_str();
  app.add_flag("--dav2-cpu", o.dav2_cpu, "Also time the engine's CPU reference of Depth-Anything-V2 (one run; ~1.4 TFLOP on one thread)");
  app.add_flag("--dav2-parts", o.dav2_parts,
               "Also time the engine's Depth-Anything-V2 cut short (no upsampler; 4 and 0 transformer layers), one run each: "
               "where its time goes");
  app.add_flag("--no-torch", no_torch, "Skip PyTorch's run of Depth-Anything-V2");
  app.add_option("--torch-matmul", o.torch_matmul,
                 "PyTorch rows by the route of the linears and attention products: onednn (torch._C._nn.mkldnn_linear, "
                 "as torch.utils.mkldnn), blas (F.linear / torch.matmul: Debian's torch uses the generic reference BLAS)")
      ->delimiter(',')
      ->check(CLI::IsMember({"onednn", "blas"}))
      ->capture_default_str();
  app.add_option("--torch-runs", o.torch_runs, "Timed PyTorch runs (the onednn row)")->capture_default_str();
  app.add_option("--torch-warmup", o.torch_warmup, "Untimed PyTorch runs first (the onednn row)")->capture_default_str();
  app.add_option("--torch-blas-runs", o.torch_blas_runs, "Timed runs of the blas row (no warm-up; minutes per forward)")
      ->capture_default_str();
  app.add_option("--keep-files", o.keep_dir, "Write PyTorch's inputs (weights, image, output) to this folder and keep them")
      ->type_name("DIR");
  CLI11_PARSE(app, argc, argv);
  o.check = !no_check;
  o.released = !no_released;
  o.rays = !no_rays;
  o.dav2 = !no_dav2;
  o.torch = !no_torch;
  auto parse_size = [](const std::string& text, int64_t& h, int64_t& w) {
    return std::sscanf(text.c_str(), "%" SCNd64 "x%" SCNd64, &h, &w) == 2 && h >= 16 && w >= 16 && h % 16 == 0 && w % 16 == 0;
  };
  if (!parse_size(size_text, o.height, o.width)) {
    std::fprintf(stderr, "icube-bench-gsm: --size must be HxW, multiples of 16 (got %s)\n", size_text.c_str());
    return 2;
  }
  if (check_size_text.empty()) {
    o.check_height = std::max<int64_t>(16, o.height / 32 * 16);
    o.check_width = std::max<int64_t>(16, o.width / 32 * 16);
  } else if (!parse_size(check_size_text, o.check_height, o.check_width)) {
    std::fprintf(stderr, "icube-bench-gsm: --check-size must be HxW, multiples of 16 (got %s)\n", check_size_text.c_str());
    return 2;
  }
  for (int64_t v : o.views)
    if (v < 1) {
      std::fprintf(stderr, "icube-bench-gsm: --views must be positive\n");
      return 2;
    }
  if (o.runs < 1 || o.dav2_runs < 1 || o.torch_runs < 1 || o.torch_blas_runs < 1 || o.warmup < 0 || o.dav2_warmup < 0 ||
      o.torch_warmup < 0) {
    std::fprintf(stderr, "icube-bench-gsm: --runs, --dav2-runs, --torch-runs and --torch-blas-runs must be >= 1, warm-ups >= 0\n");
    return 2;
  }

  gpu::Context ctx(gpu::ContextOptions::from_env());
  GsmBench b;
  b.o = o;
  b.ctx = &ctx;
  const char* lp = std::getenv("LP_NUM_THREADS");
  b.lp_threads = lp ? std::max(0, std::atoi(lp)) : 0;
  std::printf("icube-bench-gsm: the GSM on the default device\n");
  std::printf("  device         %s (%s), driver %s, %s\n", ctx.info().name.c_str(), gpu::device_type_name(ctx.info().type),
              ctx.info().driver_name.c_str(), ctx.info().driver_info.c_str());
  std::printf("  lavapipe env   LP_NUM_THREADS=%s\n", bench::env_or_unset("LP_NUM_THREADS").c_str());
  std::printf("  host           nproc %u, CPU %s\n", bench::online_cpus(), bench::cpu_model().c_str());
  std::printf("  build          %s\n", ICUBE_BENCH_BUILD_TYPE);

  Clock::time_point t0 = Clock::now();
  b.scene = bench::street_scene(*std::max_element(o.views.begin(), o.views.end()), o.height, o.width, o.seed);
  int64_t sky = 0;
  for (size_t p = 0; p < b.scene.masks.size(); p += 4) sky += b.scene.masks[p] == 0 ? 1 : 0;
  std::printf("  scene          street of %zu voxels (0.2 m), %lld views of %lld x %lld, %.0f%% sky pixels (made in %.1f s)\n",
              b.scene.voxel_ijk[0].size(), static_cast<long long>(b.scene.views), static_cast<long long>(o.height),
              static_cast<long long>(o.width), 100.0 * static_cast<double>(sky) / static_cast<double>(b.scene.masks.size() / 4),
              seconds_since(t0));
  std::fflush(stdout);

  RssSampler rss;
  b.rss = &rss;
  if (o.flops_only) {
    const nn::GsmModelConfig model = nn::load_gsm_model_config(nn::kInfinicubeGsmPreset);
    b.flops_table(model, nn::gsm_random_weights(nn::gsm_param_specs(model), o.seed));
    return 0;
  }
  if (o.check) {
    b.check_scene = o.check_height == o.height && o.check_width == o.width
                        ? b.scene
                        : bench::street_scene(b.scene.views, o.check_height, o.check_width, o.seed);
    b.check_table();
  }
  if (o.rays) b.rays_table();
  if (o.released || o.dav2) {
    const nn::GsmModelConfig model = nn::load_gsm_model_config(nn::kInfinicubeGsmPreset);
    t0 = Clock::now();
    const nn::GsmWeights w = nn::gsm_random_weights(nn::gsm_param_specs(model), o.seed);
    std::fprintf(stderr, "  released random weights drawn in %.1f s\n", seconds_since(t0));
    if (o.released) b.released_table(model, w);
    if (o.dav2) b.dav2_table(model, w);
  }
  std::printf("\npeak RSS of the run (VmHWM): %.0f MiB%s\n", static_cast<double>(status_kib("VmHWM")) / 1024.0,
              b.failed ? "; a check FAILED" : "");
  return b.failed ? 1 : 0;
}

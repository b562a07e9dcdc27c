// icube-bench-gsm: the GSM (InfiniCube's stage-3 feed-forward reconstruction
// model) on the default device, in one run:
//   check     the GPU forward (nn::GsmGpu) against the CPU reference (gsm_forward_reference) on the same
//             synthetic street at reduced widths (gsm_small's: the released structure with narrow layers),
//             every output tensor (integers exactly, floats within 1e-4 of their std)
//   released  one forward of the released widths (the infinicube-gsm preset, seeded random weights) at the
//             released input size (480 x 832 front images) for each --views count: time per stage
//             (GsmGpu::last_stages), GFLOP and GFLOP/s per stage (gsm_flops.h), host peak RSS per stage
//             (sampled), device weights and activation pool; outputs checked finite
//   dav2      Depth-Anything-V2-Large on one image: the engine's GPU stage, optionally its CPU reference,
//             and PyTorch's CPU run of the same module (bench/dav2_torch.py, Debian python3-torch) on the
//             same weights (written as .safetensors) and input, with torch threads = LP_NUM_THREADS;
//             max |diff| / std between the outputs
// The scene is bench/gsm_street_scene.h. See bench/README.md, "The GSM (issue 39)".
#include "bench_host.h"
#include "gsm_flops.h"
#include "gsm_street_scene.h"
#include "torch_side.h"

#include "gpu/context.h"
#include "nn/gsm/dav2_gpu.h"
#include "nn/gsm/gsm_gpu.h"
#include "nn/gsm/gsm_gpu_weights.h"
#include "nn/gsm/gsm_params.h"
#include "nn/gsm/gsm_preset.h"
#include "nn/gsm/gsm_random_weights.h"
#include "nn/gsm/gsm_rays.h"
#include "nn/gsm/gsm_rays_gpu.h"
#include "nn/layer_recorder.h"
#include "nn/parameter_store.h"
#include "nn/safetensors.h"
#include "world/npy.h"

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cinttypes>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

using namespace icube;
using Clock = std::chrono::steady_clock;

namespace {

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
double mib(double bytes) { return bytes / (1024.0 * 1024.0); }

struct MinMedian {
  double min = kNaN, median = kNaN;
};
MinMedian min_median(std::vector<double> v) {
  if (v.empty()) return {};
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return {v.front(), n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2])};
}

// ---- memory ----------------------------------------------------------------------------------------

long page_kib() { return sysconf(_SC_PAGESIZE) / 1024; }

// Resident set (KiB) from /proc/self/statm.
long rss_kib() {
  std::ifstream in("/proc/self/statm");
  long size = 0, resident = 0;
  in >> size >> resident;
  return resident * page_kib();
}

// A /proc/self/status field in KiB (VmHWM: peak resident set), 0 when absent.
long status_kib(const char* field) {
  std::ifstream in("/proc/self/status");
  std::string line;
  const std::string key = std::string(field) + ":";
  while (std::getline(in, line))
    if (line.rfind(key, 0) == 0) return std::atol(line.c_str() + key.size());
  return 0;
}

// Resets VmHWM to the current RSS (Linux >= 4.0); false when not allowed.
bool reset_peak_rss() {
  std::ofstream out("/proc/self/clear_refs");
  out << "5";
  return static_cast<bool>(out.flush());
}

// Samples the resident set every 5 ms on a thread of its own, for the peak inside each stage's interval.
class RssSampler {
 public:
  RssSampler() : thread_([this] { loop(); }) {}
  ~RssSampler() {
    stop_ = true;
    thread_.join();
  }
  // The largest sample in [t0, t1] (and the RSS now, in case the interval is shorter than a period).
  long peak_kib(Clock::time_point t0, Clock::time_point t1) const {
    std::lock_guard<std::mutex> lock(mutex_);
    long peak = 0;
    for (const auto& [t, kib] : samples_)
      if (t >= t0 && t <= t1) peak = std::max(peak, kib);
    return peak;
  }
  void clear() {
    std::lock_guard<std::mutex> lock(mutex_);
    samples_.clear();
  }

 private:
  void loop() {
    while (!stop_) {
      const long kib = rss_kib();
      {
        std::lock_guard<std::mutex> lock(mutex_);
        samples_.emplace_back(Clock::now(), kib);
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
  }
  std::atomic<bool> stop_{false};
  mutable std::mutex mutex_;
  std::vector<std::pair<Clock::time_point, long>> samples_;
  std::thread thread_;
};

// CPU share other processes took while a measurement ran (bench_host.h), children's CPU counted as ours.
class DisturbanceMeter {
 public:
  void start() {
    before_ = bench::cpu_times_now();
    children_before_ = children_cpu_s();
  }
  void stop() {
    const bench::CpuTimes after = bench::cpu_times_now();
    const double children = children_cpu_s() - children_before_;
    wall_ += after.wall_s - before_.wall_s;
    other_ += std::max(0.0, bench::other_cpu_seconds(before_, after) - children);
  }
  // Percent of all CPUs.
  double percent() const { return wall_ > 0 ? 100.0 * other_ / (wall_ * std::max(1u, bench::online_cpus())) : 0.0; }

 private:
  static double children_cpu_s() {
    rusage u{};
    getrusage(RUSAGE_CHILDREN, &u);
    return static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) + 1e-6 * static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
  }
  bench::CpuTimes before_;
  double children_before_ = 0, wall_ = 0, other_ = 0;
};

struct Dav2Part {
  double seconds = 0, flops = 0;
};

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

// ---- the benchmark ---------------------------------------------------------------------------------

struct Options {
  std::vector<int64_t> views{1, 4};
  int runs = 5, warmup = 1;
  int64_t height = 480, width = 832;
  int64_t check_height = 0, check_width = 0;  // 0: half of height x width
  uint32_t seed = 39;
  bool check = true, rays = true, released = true, dav2 = true, dav2_cpu = false, dav2_parts = false, torch = true, flops_only = false;
  std::vector<std::string> torch_matmul{"onednn"};
  int torch_runs = 5, torch_warmup = 1, torch_blas_runs = 1;
  int dav2_runs = 5, dav2_warmup = 1;
  std::string keep_dir;
};

struct GsmBench {
  Options o;
  gpu::Context* ctx = nullptr;
  nn::GsmInputs scene;        // the most views asked for
  nn::GsmInputs check_scene;  // the same street at the check's size
  RssSampler* rss = nullptr;
  bool failed = false;
  int lp_threads = 0;  // LP_NUM_THREADS, 0 when unset

  void check_table();
  void rays_table();
  void released_table(const nn::GsmModelConfig& model, const nn::GsmWeights& w);
  void dav2_table(const nn::GsmModelConfig& model, const nn::GsmWeights& w);
  void flops_table(const nn::GsmModelConfig& model, const nn::GsmWeights& w) const;
};

// The FLOP model (gsm_flops.h) of the released widths at each view count, without running the network.
void GsmBench::flops_table(const nn::GsmModelConfig& model, const nn::GsmWeights& w) const {
  std::printf("\nFLOP model of the released widths (gsm_flops.h; GFLOP):\n");
  std::printf("%-6s %12s %12s %12s %12s %12s %12s %12s\n", "views", "conv enc", "DAV2", "voxel br", "pixel br", "sky (host)",
              "device", "total");
  for (int64_t v : o.views) {
    const bench::GsmFlops f = bench::gsm_flops(model.config, w, bench::first_views(scene, v));
    std::printf("%-6lld %12.1f %12.1f %12.1f %12.1f %12.1f %12.1f %12.1f\n", static_cast<long long>(v), f.conv_encoder * 1e-9,
                f.dav2 * 1e-9, f.voxel_branch * 1e-9, f.pixel_branch * 1e-9, (f.sky_token + f.sky_colours) * 1e-9,
                f.device() * 1e-9, f.total() * 1e-9);
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

// The Depth-Anything-V2 tensors as a .safetensors file for bench/dav2_torch.py (state-dict names, F32; the
// BatchNorm counters left out) and the settings the script needs.
void write_dav2_for_torch(const std::filesystem::path& dir, const nn::Dav2Config& c, const nn::GsmWeights& w,
                          const nn::CpuTensor& image) {
  std::vector<nn::TensorToWrite> tensors;
  for (const auto& [name, t] : w.tensors)
    if (name.rfind("img_encoder.encoders.dav2.", 0) == 0 && name.find("num_batches_tracked") == std::string::npos)
      tensors.push_back(nn::f32_tensor(name, t.shape, t.data));
  nn::write_safetensors((dir / "dav2.safetensors").string(), tensors);
  nlohmann::json j;
  j["hidden_size"] = c.hidden_size;
  j["num_layers"] = c.num_layers;
  j["num_heads"] = c.num_heads;
  j["patch_size"] = c.patch_size;
  j["position_grid"] = c.position_grid;
  j["layer_norm_eps"] = c.layer_norm_eps;
  j["out_indices"] = c.out_indices;
  j["reassemble_factors"] = c.reassemble_factors;
  j["input_size"] = {c.input_height, c.input_width};
  nlohmann::json up = nlohmann::json::array();
  for (const nn::Dav2UpsamplerBlock& b : c.upsampler) up.push_back({{"out_dim", b.out_dim}, {"up", b.up}});
  j["upsampler"] = up;
  std::ofstream(dir / "dav2.json") << j.dump(1);
  bench::save_npy((dir / "image.npy").string(), image);
}

void GsmBench::dav2_table(const nn::GsmModelConfig& model, const nn::GsmWeights& w) {
  const nn::Dav2Config& cfg = model.config.dav2;
  nn::check_dav2_gpu(cfg, model.config.source);
  const nn::CpuTensor image = nn::gsm_images_nchw(bench::first_views(scene, 1));  // [1, 3, H, W]
  const double gflop = bench::dav2_flops_per_view(cfg, w) * 1e-9;
  const int64_t gh = cfg.input_height / cfg.patch_size, gw = cfg.input_width / cfg.patch_size;
  std::printf("\nDepth-Anything-V2-Large on one image: %lld x %lld resized to %lld x %lld, %lld x %lld patches (%lld tokens), "
              "%d layers run; %.1f GFLOP\n",
              static_cast<long long>(o.height), static_cast<long long>(o.width), static_cast<long long>(cfg.input_height),
              static_cast<long long>(cfg.input_width), static_cast<long long>(gh), static_cast<long long>(gw),
              static_cast<long long>(1 + gh * gw), static_cast<int>(*std::max_element(cfg.out_indices.begin(), cfg.out_indices.end())),
              gflop);

  // The engine on the device: a store of the stage's own tensors.
  std::unique_ptr<nn::ParameterStore> store;
  {
    const nn::GsmGpuWeights all = nn::gsm_gpu_weights(w);
    std::vector<nn::ParamSpec> specs;
    for (const nn::ParamSpec& p : all.specs)
      if (p.name.rfind("img_encoder.encoders.dav2.", 0) == 0) specs.push_back(p);
    store = std::make_unique<nn::ParameterStore>(*ctx, specs, all.tensors,
                                                 nn::ParameterStoreOptions{.network = "Depth-Anything-V2", .source = "random weights"});
  }
  std::vector<double> gpu_s;
  nn::CpuTensor gpu_out;
  DisturbanceMeter gpu_meter;
  std::vector<std::pair<std::string, Dav2Part>> parts;
  {
    nn::LayerRecorder L(*ctx, *store, "dav2-bench");
    nn::Dav2PositionEmbeddings positions;
    const nn::DeviceTensor x{std::make_shared<gpu::Buffer>(gpu::upload_vector(*ctx, image.data, "dav2-image")), image.shape};
    nn::DeviceTensor y;
    auto run = [&](const nn::Dav2Config& c) {
      y = {};
      const Clock::time_point t0 = Clock::now();
      ctx->submit_and_wait([&](gpu::CommandList& cmd) {
        L.begin(cmd);
        y = nn::dav2_gpu(L, c, x, nullptr, &positions);
        L.end();
      });
      return seconds_since(t0);
    };
    for (int r = 0; r < o.dav2_warmup + o.dav2_runs; ++r) {
      std::fprintf(stderr, "  Depth-Anything-V2 GPU: %s %d ...\n", r < o.dav2_warmup ? "warm-up" : "run",
                   r < o.dav2_warmup ? r + 1 : r - o.dav2_warmup + 1);
      if (r == o.dav2_warmup) gpu_meter.start();
      const double s = run(cfg);
      if (r >= o.dav2_warmup) gpu_s.push_back(s);
    }
    gpu_meter.stop();
    gpu_out = nn::CpuTensor(y.shape, gpu::download_vector<float>(*ctx, *y.buf, y.numel()));
    std::printf("engine output %s, activation pool %.0f MiB, weights %.0f MiB on the device\n", gpu_out.shape_text().c_str(),
                mib(static_cast<double>(L.pool().bytes())), mib(static_cast<double>(store->device_bytes())));
    if (o.dav2_parts) {
      // The same stage cut short, one run each: without the upsampler, then with only 4 and 0 transformer layers.
      nn::Dav2Config no_up = cfg;
      no_up.upsampler.clear();
      nn::Dav2Config four = no_up, none = no_up;
      four.out_indices = {1, 2, 3, 4};
      none.out_indices = {0, 0, 0, 0};
      for (const auto& [label, c] : {std::make_pair("backbone + neck, no upsampler", no_up),
                                     std::make_pair("4 layers + neck", four), std::make_pair("embeddings + neck", none)}) {
        std::fprintf(stderr, "  Depth-Anything-V2 GPU part: %s ...\n", label);
        parts.emplace_back(label, Dav2Part{run(c), bench::dav2_flops_per_view(c, w)});
      }
    }
  }
  store.reset();

  nn::CpuTensor cpu_out;
  double cpu_s = kNaN;
  DisturbanceMeter cpu_meter;
  if (o.dav2_cpu) {
    std::fprintf(stderr, "  Depth-Anything-V2 CPU reference ...\n");
    cpu_meter.start();
    const Clock::time_point t0 = Clock::now();
    cpu_out = nn::dav2_features(cfg, w, image);
    cpu_s = seconds_since(t0);
    cpu_meter.stop();
  }

  // PyTorch, once per matmul route (bench/dav2_torch.py --matmul).
  struct TorchRow {
    std::string matmul, note;
    int runs = 0;
    bench::TorchSide::Result r;
    DisturbanceMeter meter;
  };
  std::vector<TorchRow> torch_rows;
  const int torch_threads = lp_threads > 0 ? lp_threads : static_cast<int>(std::max(1u, bench::online_cpus()));
  const std::string python = o.torch ? bench::python_with_torch() : "";
  std::string torch_skipped;
  if (!o.torch) {
    torch_skipped = "skipped (--no-torch)";
  } else if (python.empty()) {
    torch_skipped = "skipped: no python3 with torch and numpy (Debian python3-torch)";
  } else {
    const std::filesystem::path dir = o.keep_dir.empty()
                                          ? std::filesystem::temp_directory_path() / ("icube-bench-gsm-" + std::to_string(getpid()))
                                          : std::filesystem::path(o.keep_dir);
    std::filesystem::create_directories(dir);
    std::fprintf(stderr, "  PyTorch: writing the weights to %s ...\n", dir.c_str());
    write_dav2_for_torch(dir, cfg, w, image);
    for (const std::string& matmul : o.torch_matmul) {
      TorchRow row;
      row.matmul = matmul;
      row.runs = matmul == "blas" ? o.torch_blas_runs : o.torch_runs;
      const int warmup = matmul == "blas" ? 0 : o.torch_warmup;
      const std::string cmd = python + " " + ICUBE_SOURCE_DIR + "/bench/dav2_torch.py --dir '" + dir.string() + "' --threads " +
                              std::to_string(torch_threads) + " --runs " + std::to_string(row.runs) + " --warmup " +
                              std::to_string(warmup) + " --matmul " + matmul;
      std::fprintf(stderr, "  PyTorch: %s\n", cmd.c_str());
      row.meter.start();
      const auto [status, text] = bench::capture(cmd);
      row.meter.stop();
      if (status != 0 || text.find('{') == std::string::npos) {
        row.note = "FAILED (see stderr)";
        std::fprintf(stderr, "dav2_torch.py failed:\n%s\n", text.c_str());
        failed = true;
      } else {
        const nlohmann::json j = nlohmann::json::parse(text.substr(text.rfind('{')));
        row.r.min_ms = j.at("min_ms").get<double>();
        row.r.median_ms = j.at("median_ms").get<double>();
        row.r.y = world::read_npy((dir / "y.npy").string()).values<float>();
        row.r.ok = true;
        row.note = "PyTorch " + j.value("torch", std::string("?")) + " CPU, " + (matmul == "blas" ? "BLAS matmuls" : "oneDNN matmuls");
      }
      torch_rows.push_back(std::move(row));
    }
    if (o.keep_dir.empty()) std::filesystem::remove_all(dir);
  }

  auto diff = [](const std::vector<float>& a, const std::vector<float>& b) {
    return a.size() == b.size() && !a.empty() ? nn::cpu::max_abs_over_std(a, b) : kNaN;
  };
  const std::vector<float>* reference = nullptr;  // the first PyTorch output
  for (const TorchRow& t : torch_rows)
    if (t.r.ok && !reference) reference = &t.r.y;
  std::printf("%-44s %8s %10s %10s %9s %5s %7s  %s\n", "implementation", "threads", "min s", "median s", "GFLOP/s", "runs",
              "other%", "max |diff| / std(torch)");
  const MinMedian g = min_median(gpu_s);
  const std::string device = "engine GPU (" + ctx->info().name + ")";
  std::printf("%-44.44s %8s %10.2f %10.2f %9.1f %5d %7.0f  %.2e\n", device.c_str(),
              lp_threads > 0 ? std::to_string(lp_threads).c_str() : "-", g.min, g.median, gflop / g.min, o.dav2_runs,
              gpu_meter.percent(), reference ? diff(gpu_out.data, *reference) : kNaN);
  if (o.dav2_cpu)
    std::printf("%-44s %8d %10.2f %10.2f %9.1f %5d %7.0f  %.2e (GPU against it: %.2e)\n", "engine CPU reference (dav2_features)", 1,
                cpu_s, cpu_s, gflop / cpu_s, 1, cpu_meter.percent(), reference ? diff(cpu_out.data, *reference) : kNaN,
                diff(gpu_out.data, cpu_out.data));
  for (const TorchRow& t : torch_rows) {
    if (!t.r.ok) {
      std::printf("%-44s %s\n", ("PyTorch (--matmul " + t.matmul + ")").c_str(), t.note.c_str());
      continue;
    }
    char against[32] = "-";  // the first PyTorch row is the reference
    if (&t.r.y != reference) std::snprintf(against, sizeof against, "%.2e", diff(t.r.y, *reference));
    std::printf("%-44.44s %8d %10.2f %10.2f %9.1f %5d %7.0f  %s\n", t.note.c_str(), torch_threads, t.r.min_ms * 1e-3,
                t.r.median_ms * 1e-3, gflop / (t.r.min_ms * 1e-3), t.runs, t.meter.percent(), against);
  }
  if (!torch_skipped.empty()) std::printf("%-44s %s\n", "PyTorch CPU (bench/dav2_torch.py)", torch_skipped.c_str());
  if (!parts.empty()) {
    std::printf("\nwhere the engine's time goes (one run each, the same device and input):\n");
    std::printf("%-44s %10s %9s %9s\n", "part", "s", "GFLOP", "GFLOP/s");
    const double full = g.min, full_flops = gflop * 1e9;
    const Dav2Part& a24 = parts[0].second;
    const Dav2Part& a4 = parts[1].second;
    const Dav2Part& a0 = parts[2].second;
    const int64_t layers = std::min(cfg.num_layers, *std::max_element(cfg.out_indices.begin(), cfg.out_indices.end()));
    auto row = [](const char* label, double sec, double flops) {
      std::printf("%-44s %10.2f %9.1f %9.1f\n", label, sec, flops * 1e-9, sec > 0 ? flops * 1e-9 / sec : 0.0);
    };
    for (const auto& [label, p] : parts) row(label.c_str(), p.seconds, p.flops);
    row("= upsampler (full - no upsampler)", full - a24.seconds, full_flops - a24.flops);
    row("= one transformer layer ((4 - 0 layers) / 4)", (a4.seconds - a0.seconds) / 4, (a4.flops - a0.flops) / 4);
    const std::string all = "= all " + std::to_string(layers) + " transformer layers (" + std::to_string(layers) + " - 0 layers)";
    row(all.c_str(), a24.seconds - a0.seconds, a24.flops - a0.flops);
  }
  const double tolerance = 1e-4;
  if (reference && !(diff(gpu_out.data, *reference) <= tolerance)) {
    std::fprintf(stderr, "Depth-Anything-V2: the engine's output differs from PyTorch's by more than %.0e of its std\n", tolerance);
    failed = true;
  }
  std::fflush(stdout);
}

}  // namespace

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

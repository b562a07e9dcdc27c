// icube-bench-gsm's shared parts (bench/bench_gsm.cpp: the check, pixel-ray,
// released-width and FLOP tables and main; bench/bench_gsm_dav2.cpp: the
// Depth-Anything-V2 table against PyTorch): the options, the run's state and
// its small helpers.
#pragma once

#include "bench_stats.h"
#include "process_memory.h"

#include "gpu/context.h"
#include "nn/gsm/gsm_inputs.h"
#include "nn/gsm/gsm_params.h"
#include "nn/gsm/gsm_weights.h"

#include <chrono>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

namespace icube::bench {

using Clock = std::chrono::steady_clock;

inline double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
inline double mib(double bytes) { return bytes / (1024.0 * 1024.0); }

// Min and median of samples in seconds (bench_stats.h's summarize, whose fields are unit-free).
struct MinMedian {
  double min = kNaN, median = kNaN;
};
inline MinMedian min_median(const std::vector<double>& seconds) {
  const Summary s = summarize(seconds);
  return {s.min_ms, s.median_ms};
}

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

}  // namespace icube::bench

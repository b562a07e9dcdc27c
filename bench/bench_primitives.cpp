// icube-bench: times the GPU prefix scan and radix sort (kernels/) against CPU
// std:: algorithms on identical fixed-seed data, in one run, and checks every
// result against the CPU reference. See bench/README.md.
//
//   scan    kernels::PrefixScan inclusive  vs std::inclusive_scan
//   sort32  kernels::RadixSort Bits32      vs std::stable_sort / std::sort of (key, value)
//   sort64  kernels::RadixSort Bits64      vs std::stable_sort of (key, value),
//           keys = tile id << 32 | float depth bits (a splatting rasterizer's sort)
//
// GPU rows: kernel time from GPU timestamps around record() and wall time of
// that one submit_and_wait; upload and download are timed once per size.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <bit>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <functional>
#include <nlohmann/json.hpp>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "bench_cpu.h"
#include "bench_host.h"
#include "bench_stats.h"
#include "gpu/buffer.h"
#include "gpu/commands.h"
#include "gpu/context.h"
#include "kernels/prefix_scan.h"
#include "kernels/radix_sort.h"

#ifndef ICUBE_BENCH_BUILD_TYPE
#define ICUBE_BENCH_BUILD_TYPE "unknown"
#endif
#if defined(__clang__)
#define ICUBE_BENCH_COMPILER "clang " __VERSION__
#elif defined(__GNUC__)
#define ICUBE_BENCH_COMPILER "gcc " __VERSION__
#else
#define ICUBE_BENCH_COMPILER "unknown compiler"
#endif

namespace icube::bench {
namespace {

using Clock = std::chrono::steady_clock;
using RecordFn = std::function<void(gpu::CommandList&)>;

// Screen tiles of the sort64 keys: 1920x1080 in 16x16 tiles (120 x 68).
constexpr uint32_t kSplatTiles = 120 * 68;

// Rows measured while other processes took more than this share of the CPUs are flagged.
constexpr double kDisturbedShare = 0.05;

struct Options {
  std::vector<uint64_t> sizes;
  std::vector<std::string> ops;
  int runs = 7;
  int warmup = 2;
  unsigned cpu_threads = 1;
  uint64_t seed = 20240601;
  std::string json_path;
};

// Everything a run needs: the context, the options and the collected rows.
struct Bench {
  gpu::Context& ctx;
  const Options& opt;
  std::vector<ResultRow> rows;
  bool failed = false;
};

// ---- machine description -----------------------------------------------------

nlohmann::json machine_json(const gpu::Context& ctx, const Options& opt) {
  const gpu::DeviceInfo& d = ctx.info();
  return {{"device", d.name},
          {"device_type", gpu::device_type_name(d.type)},
          {"vulkan_api", gpu::api_version_string(d.api_version)},
          {"driver_name", d.driver_name},
          {"driver_info", d.driver_info},
          {"subgroup_size", ctx.subgroup_size()},
          {"timestamps", d.timestamps_on_compute && d.timestamp_period_ns > 0.0f},
          {"timestamp_period_ns", static_cast<double>(d.timestamp_period_ns)},
          {"LP_NUM_THREADS", env_or_unset("LP_NUM_THREADS")},
          {"LP_NATIVE_VECTOR_WIDTH", env_or_unset("LP_NATIVE_VECTOR_WIDTH")},
          {"nproc", online_cpus()},
          {"cpu_model", cpu_model()},
          {"cpu_threads", opt.cpu_threads},
          {"compiler", ICUBE_BENCH_COMPILER},
          {"build_type", ICUBE_BENCH_BUILD_TYPE}};
}

std::string str(const nlohmann::json& j) { return j.is_string() ? j.get<std::string>() : j.dump(); }

void print_header(const nlohmann::json& m, const Options& opt, bool is_cpu_device) {
  std::printf("icube-bench: GPU prefix scan and radix sort vs CPU std:: algorithms\n");
  std::printf("  device         %s (%s), Vulkan %s\n", str(m["device"]).c_str(), str(m["device_type"]).c_str(),
              str(m["vulkan_api"]).c_str());
  std::printf("  driver         %s, %s\n", str(m["driver_name"]).c_str(), str(m["driver_info"]).c_str());
  std::printf("  subgroup size  %s, GPU timestamps %s\n", str(m["subgroup_size"]).c_str(),
              m["timestamps"].get<bool>() ? "yes" : "no (kernel rows n/a)");
  std::printf("  lavapipe env   LP_NUM_THREADS=%s LP_NATIVE_VECTOR_WIDTH=%s\n", str(m["LP_NUM_THREADS"]).c_str(),
              str(m["LP_NATIVE_VECTOR_WIDTH"]).c_str());
  std::printf("  host           nproc %s, CPU %s\n", str(m["nproc"]).c_str(), str(m["cpu_model"]).c_str());
  std::printf("  cpu threads    %u (--cpu-threads)\n", opt.cpu_threads);
  std::printf("  runs           %d timed (+%d warmup) per implementation, seed %llu\n", opt.runs, opt.warmup,
              static_cast<unsigned long long>(opt.seed));
  std::printf("  build          %s, %s\n", str(m["build_type"]).c_str(), str(m["compiler"]).c_str());
  const std::string lp = env_or_unset("LP_NUM_THREADS");
  if (is_cpu_device && lp != std::to_string(opt.cpu_threads))
    std::printf(
        "  note           LP_NUM_THREADS=%s but --cpu-threads %u: GPU and CPU sides use different "
        "thread counts (compare with LP_NUM_THREADS=2 --cpu-threads 2)\n",
        lp.c_str(), opt.cpu_threads);
  std::printf("\n");
  std::fflush(stdout);
}

// ---- fixed-seed inputs -----------------------------------------------------------

std::mt19937_64 make_rng(uint64_t seed, uint32_t op_id, uint64_t n) {
  std::seed_seq seq{static_cast<uint32_t>(seed), static_cast<uint32_t>(seed >> 32), op_id, static_cast<uint32_t>(n),
                    static_cast<uint32_t>(n >> 32)};
  return std::mt19937_64(seq);
}

std::vector<uint32_t> make_scan_input(uint64_t seed, uint64_t n) {
  std::mt19937_64 rng = make_rng(seed, 1, n);
  std::vector<uint32_t> v(n);
  for (uint32_t& x : v) x = static_cast<uint32_t>(rng());  // full range: the sums wrap
  return v;
}

template <class K>
struct SortInput {
  std::vector<K> keys;
  std::vector<uint32_t> values;  // original indices
  uint32_t key_bits = 0;         // bits the sort orders by
};

SortInput<uint32_t> make_sort32_input(uint64_t seed, uint64_t n) {
  std::mt19937_64 rng = make_rng(seed, 2, n);
  SortInput<uint32_t> in{std::vector<uint32_t>(n), std::vector<uint32_t>(n), 32};
  for (uint64_t i = 0; i < n; ++i) {
    in.keys[i] = static_cast<uint32_t>(rng());
    in.values[i] = static_cast<uint32_t>(i);
  }
  return in;
}

// Gaussian-splatting style keys: random screen tile in the high word, the
// bits of a positive float depth in [0.1, 500) in the low word.
SortInput<uint64_t> make_sort64_input(uint64_t seed, uint64_t n) {
  std::mt19937_64 rng = make_rng(seed, 3, n);
  const uint32_t key_bits = 32 + static_cast<uint32_t>(std::bit_width(kSplatTiles - 1));
  SortInput<uint64_t> in{std::vector<uint64_t>(n), std::vector<uint32_t>(n), key_bits};
  for (uint64_t i = 0; i < n; ++i) {
    const uint64_t r = rng();
    const uint32_t tile = static_cast<uint32_t>((r >> 40) % kSplatTiles);
    const float depth = 0.1f + static_cast<float>(r & 0xffffff) * (499.9f / 16777216.0f);
    uint32_t depth_bits = 0;
    std::memcpy(&depth_bits, &depth, sizeof(depth_bits));
    in.keys[i] = (static_cast<uint64_t>(tile) << 32) | depth_bits;
    in.values[i] = static_cast<uint32_t>(i);
  }
  return in;
}

// ---- timing ----------------------------------------------------------------------

double elapsed_ms(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

double time_once_ms(const std::function<void()>& body) {
  const Clock::time_point t0 = Clock::now();
  body();
  return elapsed_ms(t0);
}

struct GpuTimes {
  std::vector<double> kernel_ms;
  std::vector<double> submit_ms;
};

// Runs `record` warmup + runs times, each in its own submit_and_wait with GPU
// timestamps around it. `restore` (optional) runs in a separate, untimed
// submission before each run, e.g. to copy the unsorted input back.
GpuTimes time_gpu(Bench& b, const RecordFn& restore, const RecordFn& record) {
  gpu::GpuTimer timer(b.ctx, 1);
  GpuTimes t;
  int interval = 0;
  for (int i = 0; i < b.opt.warmup + b.opt.runs; ++i) {
    if (restore) b.ctx.submit_and_wait(restore);
    const Clock::time_point t0 = Clock::now();
    b.ctx.submit_and_wait([&](gpu::CommandList& cmd) {
      timer.reset(cmd);
      cmd.barrier(gpu::deps::kTransferToCompute);  // the restored inputs
      cmd.barrier(gpu::deps::kComputeToCompute);   // the previous run's writes
      interval = timer.begin(cmd, "record");
      record(cmd);
      timer.end(cmd, interval);
    });
    const double wall = elapsed_ms(t0);
    if (i < b.opt.warmup) continue;
    t.kernel_ms.push_back(timer.milliseconds(interval));
    t.submit_ms.push_back(wall);
  }
  return t;
}

// Runs `body` warmup + runs times; `prepare` (optional) runs untimed before each.
std::vector<double> time_cpu(const Bench& b, const std::function<void()>& prepare, const std::function<void()>& body) {
  std::vector<double> samples;
  for (int i = 0; i < b.opt.warmup + b.opt.runs; ++i) {
    if (prepare) prepare();
    const double ms = time_once_ms(body);
    if (i >= b.opt.warmup) samples.push_back(ms);
  }
  return samples;
}

// ---- progress and checks --------------------------------------------------------------

// Progress of one implementation at one size: a line on stderr, and the CPU
// time other processes took meanwhile (their share of all CPUs, 0..1).
struct Progress {
  CpuTimes start;
};

Progress progress_begin(const Bench& b, const std::string& op, uint64_t n, const std::string& what) {
  std::fprintf(stderr, "[icube-bench] %-6s n=%-9llu %s (%d+%d runs) ...", op.c_str(),
               static_cast<unsigned long long>(n), what.c_str(), b.opt.warmup, b.opt.runs);
  std::fflush(stderr);
  return {cpu_times_now()};
}

double progress_end(const Progress& p, const std::vector<double>& samples) {
  const CpuTimes now = cpu_times_now();
  const double wall = now.wall_s - p.start.wall_s;
  const double cpus = std::max(1u, online_cpus());
  const double share = wall > 0.0 ? other_cpu_seconds(p.start, now) / (wall * cpus) : 0.0;
  std::fprintf(stderr, " min %.2f ms (%.1f s, other processes %.0f%% of the CPUs)\n", summarize(samples).min_ms, wall,
               100.0 * share);
  return share;
}

template <class T>
bool equal_or_report(const std::vector<T>& got, const std::vector<T>& want, const std::string& what) {
  if (got.size() != want.size()) {
    std::fprintf(stderr, "FAIL %s: %zu elements, expected %zu\n", what.c_str(), got.size(), want.size());
    return false;
  }
  for (size_t i = 0; i < got.size(); ++i) {
    if (got[i] == want[i]) continue;
    std::fprintf(stderr, "FAIL %s: first mismatch at %zu: got %llu, want %llu\n", what.c_str(), i,
                 static_cast<unsigned long long>(got[i]), static_cast<unsigned long long>(want[i]));
    return false;
  }
  return true;
}

template <class K>
bool pairs_equal_or_report(const std::vector<KeyValue<K>>& got, const SortInput<K>& want, const std::string& what) {
  std::vector<K> keys(got.size());
  std::vector<uint32_t> values(got.size());
  for (size_t i = 0; i < got.size(); ++i) {
    keys[i] = got[i].key;
    values[i] = got[i].value;
  }
  return equal_or_report(keys, want.keys, what + " keys") && equal_or_report(values, want.values, what + " values");
}

void add_row(Bench& b, const std::string& op, uint64_t n, const std::string& impl, const std::string& timing,
             std::vector<double> samples, const std::string& check, double others) {
  if (check == "FAIL") b.failed = true;
  b.rows.push_back({op, n, impl, timing, std::move(samples), check, others});
}

void add_gpu_rows(Bench& b, const std::string& op, uint64_t n, const std::string& impl, const GpuTimes& t, bool ok,
                  double others) {
  add_row(b, op, n, impl + ": kernel (timestamps)", "gpu-kernel", t.kernel_ms, ok ? "ok" : "FAIL", others);
  add_row(b, op, n, impl + ": submit (wall)", "gpu-submit", t.submit_ms, ok ? "ok" : "FAIL", others);
}

void add_transfer_rows(Bench& b, const std::string& op, uint64_t n, double upload_ms, double download_ms) {
  add_row(b, op, n, "gpu upload (once, not in the runs)", "transfer", {upload_ms}, "-", 0.0);
  add_row(b, op, n, "gpu download (once, not in the runs)", "transfer", {download_ms}, "-", 0.0);
}

// ---- scan -----------------------------------------------------------------------------

void bench_gpu_scan(Bench& b, const std::vector<uint32_t>& in, const std::vector<uint32_t>& reference) {
  const uint64_t n = in.size();
  gpu::Buffer in_buf(b.ctx, n * 4, gpu::MemoryUsage::DeviceLocal, "bench-scan-in");
  gpu::Buffer out_buf(b.ctx, n * 4, gpu::MemoryUsage::DeviceLocal, "bench-scan-out");
  gpu::Buffer scratch(b.ctx, std::max<uint64_t>(kernels::PrefixScan::scratch_elements(n), 1) * 4,
                      gpu::MemoryUsage::DeviceLocal, "bench-scan-scratch");
  kernels::PrefixScan scan(b.ctx);
  const double upload_ms = time_once_ms([&] { gpu::upload(b.ctx, in_buf, in.data(), n * 4); });

  const std::string impl = "gpu PrefixScan inclusive";
  const Progress progress = progress_begin(b, "scan", n, impl);
  const GpuTimes t = time_gpu(b, nullptr, [&](gpu::CommandList& cmd) {
    scan.record(cmd, in_buf, out_buf, n, kernels::ScanKind::Inclusive, &scratch);
  });
  const double others = progress_end(progress, t.kernel_ms);

  std::vector<uint32_t> got(n);
  const double download_ms = time_once_ms([&] { gpu::download(b.ctx, out_buf, got.data(), n * 4); });
  add_gpu_rows(b, "scan", n, impl, t, equal_or_report(got, reference, "scan " + impl), others);
  add_transfer_rows(b, "scan", n, upload_ms, download_ms);
}

void bench_cpu_scan(Bench& b, const std::vector<uint32_t>& in, const std::vector<uint32_t>& reference) {
  const uint64_t n = in.size();
  const std::string impl = cpu_scan_name(b.opt.cpu_threads);
  std::vector<uint32_t> out(n);
  const Progress progress = progress_begin(b, "scan", n, impl);
  std::vector<double> samples = time_cpu(b, nullptr, [&] { cpu_inclusive_scan(in, out, b.opt.cpu_threads); });
  const double others = progress_end(progress, samples);
  add_row(b, "scan", n, impl, "cpu", std::move(samples),
          equal_or_report(out, reference, "scan " + impl) ? "ok" : "FAIL", others);
}

void bench_scan(Bench& b, uint64_t n) {
  const std::vector<uint32_t> in = make_scan_input(b.opt.seed, n);
  const std::vector<uint32_t> reference = kernels::prefix_scan_cpu(in, kernels::ScanKind::Inclusive);
  bench_gpu_scan(b, in, reference);
  bench_cpu_scan(b, in, reference);
}

// ---- sorts ----------------------------------------------------------------------------

template <class K>
void bench_gpu_sort(Bench& b, const std::string& op, const SortInput<K>& input, const SortInput<K>& reference,
                    kernels::KeyWidth width) {
  const uint64_t n = input.keys.size();
  const std::string impl = std::string("gpu RadixSort ") + (width == kernels::KeyWidth::Bits64 ? "Bits64" : "Bits32") +
                           " " + std::to_string(input.key_bits) + "-bit";
  kernels::RadixSort sort(b.ctx, width);
  if (n > sort.max_elements()) {
    std::fprintf(stderr, "[icube-bench] %s n=%llu: skipping %s, more than %llu keys do not fit one binding\n",
                 op.c_str(), static_cast<unsigned long long>(n), impl.c_str(),
                 static_cast<unsigned long long>(sort.max_elements()));
    add_row(b, op, n, impl, "gpu-kernel", {}, "skip", 0.0);
    return;
  }
  const uint64_t key_bytes = n * sizeof(K);
  gpu::Buffer pristine_keys(b.ctx, key_bytes, gpu::MemoryUsage::DeviceLocal, "bench-sort-keys-in");
  gpu::Buffer pristine_values(b.ctx, n * 4, gpu::MemoryUsage::DeviceLocal, "bench-sort-values-in");
  gpu::Buffer keys(b.ctx, key_bytes, gpu::MemoryUsage::DeviceLocal, "bench-sort-keys");
  gpu::Buffer values(b.ctx, n * 4, gpu::MemoryUsage::DeviceLocal, "bench-sort-values");
  kernels::RadixSortScratch scratch(b.ctx, n, width);
  const double upload_ms = time_once_ms([&] {
    gpu::upload(b.ctx, pristine_keys, input.keys.data(), key_bytes);
    gpu::upload(b.ctx, pristine_values, input.values.data(), n * 4);
  });

  const RecordFn restore = [&](gpu::CommandList& cmd) {
    cmd.barrier(gpu::deps::kComputeToTransfer);  // the previous run's sort read and wrote keys/values
    cmd.copy_buffer(pristine_keys.binding(0, key_bytes), keys.binding(0, key_bytes));
    cmd.copy_buffer(pristine_values.binding(0, n * 4), values.binding(0, n * 4));
  };
  const Progress progress = progress_begin(b, op, n, impl);
  const GpuTimes t =
      time_gpu(b, restore, [&](gpu::CommandList& cmd) { sort.record(cmd, keys, values, n, scratch, input.key_bits); });
  const double others = progress_end(progress, t.kernel_ms);

  std::vector<K> got_keys(n);
  std::vector<uint32_t> got_values(n);
  const double download_ms = time_once_ms([&] {
    gpu::download(b.ctx, keys, got_keys.data(), key_bytes);
    gpu::download(b.ctx, values, got_values.data(), n * 4);
  });
  const bool ok = equal_or_report(got_keys, reference.keys, op + " " + impl + " keys") &&
                  equal_or_report(got_values, reference.values, op + " " + impl + " values");
  add_gpu_rows(b, op, n, impl, t, ok, others);
  add_transfer_rows(b, op, n, upload_ms, download_ms);
}

template <class K>
void bench_cpu_sort(Bench& b, const std::string& op, const std::vector<KeyValue<K>>& pairs,
                    const SortInput<K>& reference, const std::string& impl,
                    void (*sort_fn)(std::vector<KeyValue<K>>&, unsigned)) {
  const uint64_t n = pairs.size();
  std::vector<KeyValue<K>> work;
  work.reserve(n);
  const Progress progress = progress_begin(b, op, n, impl);
  std::vector<double> samples = time_cpu(
      b, [&] { work.assign(pairs.begin(), pairs.end()); }, [&] { sort_fn(work, b.opt.cpu_threads); });
  const double others = progress_end(progress, samples);
  add_row(b, op, n, impl, "cpu", std::move(samples),
          pairs_equal_or_report(work, reference, op + " " + impl) ? "ok" : "FAIL", others);
}

template <class K>
void bench_sort(Bench& b, const std::string& op, const SortInput<K>& input, kernels::KeyWidth width,
                bool with_std_sort) {
  const uint64_t n = input.keys.size();
  std::fprintf(stderr, "[icube-bench] %-6s n=%-9llu CPU reference (kernels::radix_sort_cpu) ...\n", op.c_str(),
               static_cast<unsigned long long>(n));
  SortInput<K> reference = input;
  kernels::radix_sort_cpu(reference.keys, reference.values, input.key_bits);

  bench_gpu_sort(b, op, input, reference, width);
  std::vector<KeyValue<K>> pairs(n);
  for (uint64_t i = 0; i < n; ++i) pairs[i] = {input.keys[i], input.values[i]};
  bench_cpu_sort<K>(b, op, pairs, reference, cpu_stable_sort_name(b.opt.cpu_threads), &cpu_stable_sort_by_key<K>);
  if (with_std_sort)
    bench_cpu_sort<K>(b, op, pairs, reference, cpu_sort_name(b.opt.cpu_threads), &cpu_sort_by_key_value<K>);
}

bool wants(const Options& opt, const std::string& op) {
  return std::find(opt.ops.begin(), opt.ops.end(), op) != opt.ops.end();
}

void run_all(Bench& b) {
  for (uint64_t n : b.opt.sizes) {
    if (wants(b.opt, "scan")) bench_scan(b, n);
    if (wants(b.opt, "sort32"))
      bench_sort(b, "sort32", make_sort32_input(b.opt.seed, n), kernels::KeyWidth::Bits32, true);
    if (wants(b.opt, "sort64"))
      bench_sort(b, "sort64", make_sort64_input(b.opt.seed, n), kernels::KeyWidth::Bits64, false);
  }
}

// ---- command line ---------------------------------------------------------------------

// "1e6", "4000000", "16M", "500k" -> element count; throws on anything else.
uint64_t parse_size(const std::string& text) {
  size_t used = 0;
  double v = 0.0;
  try {
    v = std::stod(text, &used);
  } catch (const std::exception&) {
    throw std::invalid_argument("--sizes: '" + text + "' is not a number");
  }
  const std::string suffix = text.substr(used);
  if (suffix == "k" || suffix == "K")
    v *= 1e3;
  else if (suffix == "m" || suffix == "M")
    v *= 1e6;
  else if (!suffix.empty())
    throw std::invalid_argument("--sizes: unknown suffix in '" + text + "' (use k or M)");
  if (!(v >= 1.0) || v > 4e9 || v != static_cast<double>(static_cast<uint64_t>(v)))
    throw std::invalid_argument("--sizes: '" + text + "' is not a whole element count in [1, 4e9]");
  return static_cast<uint64_t>(v);
}

nlohmann::json config_json(const Options& opt) {
  return {{"sizes", opt.sizes},
          {"ops", opt.ops},
          {"runs", opt.runs},
          {"warmup", opt.warmup},
          {"cpu_threads", opt.cpu_threads},
          {"seed", opt.seed},
          {"sort64_tiles", kSplatTiles}};
}

int run(const Options& opt) {
  gpu::Context ctx(gpu::ContextOptions::from_env());
  const nlohmann::json machine = machine_json(ctx, opt);
  print_header(machine, opt, ctx.info().type == VK_PHYSICAL_DEVICE_TYPE_CPU);
  Bench b{ctx, opt, {}, false};
  const CpuTimes start = cpu_times_now();
  run_all(b);
  const CpuTimes end = cpu_times_now();
  const double wall_s = end.wall_s - start.wall_s;
  const double others = other_cpu_seconds(start, end) / (wall_s * std::max(1u, online_cpus()));
  print_table(b.rows);
  print_disturbed_rows(b.rows, kDisturbedShare);
  std::printf("\nrun: %.1f s wall, other processes took %.0f%% of the CPUs\n", wall_s, 100.0 * others);
  if (ctx.message_count())
    std::printf("\nnote: %llu validation/driver message(s) during the run\n",
                static_cast<unsigned long long>(ctx.message_count()));
  if (!opt.json_path.empty()) {
    nlohmann::json rows = nlohmann::json::array();
    for (const ResultRow& r : b.rows) rows.push_back(row_to_json(r));
    write_json_file(opt.json_path, {{"tool", "icube-bench"},
                                    {"machine", machine},
                                    {"config", config_json(opt)},
                                    {"run", {{"wall_s", wall_s}, {"other_cpu_share", others}}},
                                    {"passed", !b.failed},
                                    {"results", rows}});
    std::printf("\nwrote %s\n", opt.json_path.c_str());
  }
  if (b.failed) {
    std::printf("\nFAIL: a GPU or CPU result differs from the CPU reference (details on stderr)\n");
    return 1;
  }
  return 0;
}

}  // namespace
}  // namespace icube::bench

int main(int argc, char** argv) {
  using namespace icube::bench;
  CLI::App app{"icube-bench: GPU prefix scan and radix sort vs CPU std:: algorithms on identical fixed-seed data",
               "icube-bench"};
  Options opt;
  std::vector<std::string> sizes = {"1e6", "4e6", "16e6"};
  opt.ops = {"scan", "sort32", "sort64"};
  app.add_option("--sizes", sizes, "Element counts, comma separated (1e6, 4000000, 16M)")
      ->delimiter(',')
      ->capture_default_str();
  app.add_option("--ops", opt.ops, "Ops to run, comma separated")
      ->delimiter(',')
      ->check(CLI::IsMember({"scan", "sort32", "sort64"}))
      ->capture_default_str();
  app.add_option("--runs", opt.runs, "Timed runs per implementation (min and median over these)")
      ->check(CLI::Range(5, 100000))
      ->capture_default_str();
  app.add_option("--warmup", opt.warmup, "Untimed runs before the timed ones")
      ->check(CLI::Range(0, 1000))
      ->capture_default_str();
  app.add_option("--cpu-threads", opt.cpu_threads, "std::threads for the CPU implementations (match LP_NUM_THREADS)")
      ->check(CLI::Range(1u, 256u))
      ->capture_default_str();
  app.add_option("--seed", opt.seed, "Seed of the fixed input data")->capture_default_str();
  app.add_option("--json", opt.json_path, "Also write the results as JSON to this file");
  app.footer(
      "Compare at equal thread counts: LP_NUM_THREADS=2 icube-bench --cpu-threads 2\n"
      "Environment: ICUBE_DEVICE=<index|name substring>, ICUBE_VALIDATION=1, LP_NUM_THREADS, LP_NATIVE_VECTOR_WIDTH");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  try {
    for (const std::string& s : sizes) opt.sizes.push_back(parse_size(s));
    return run(opt);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "icube-bench: error: %s\n", e.what());
    return 1;
  }
}

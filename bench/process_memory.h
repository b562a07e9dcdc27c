// The benchmarks' view of their own process: the resident set now and its
// peak (/proc/self/statm, /proc/self/status), a thread that samples the
// resident set every 5 ms (for the peak inside a stage's interval), and the
// CPU share other processes took while a measurement ran (bench_host.h's
// meter, the children's CPU counted as ours). Linux only. Used by
// icube-bench-gsm (bench/bench_gsm.cpp, bench/bench_gsm_dav2.cpp).
#pragma once

#include "bench_host.h"

#include <atomic>
#include <chrono>
#include <mutex>
#include <thread>
#include <utility>
#include <vector>

namespace icube::bench {

// Resident set (KiB) from /proc/self/statm.
long rss_kib();
// A /proc/self/status field in KiB (VmHWM: peak resident set), 0 when absent.
long status_kib(const char* field);
// Resets VmHWM to the current RSS (Linux >= 4.0); false when not allowed.
bool reset_peak_rss();

// Samples the resident set every 5 ms on a thread of its own, for the peak inside each stage's interval.
class RssSampler {
 public:
  using Clock = std::chrono::steady_clock;
  RssSampler();
  ~RssSampler();
  // The largest sample in [t0, t1].
  long peak_kib(Clock::time_point t0, Clock::time_point t1) const;
  void clear();

 private:
  void loop();
  std::atomic<bool> stop_{false};
  mutable std::mutex mutex_;
  std::vector<std::pair<Clock::time_point, long>> samples_;
  std::thread thread_;
};

// CPU share other processes took while a measurement ran (bench_host.h), children's CPU counted as ours.
class DisturbanceMeter {
 public:
  void start();
  void stop();
  // Percent of all CPUs.
  double percent() const;

 private:
  CpuTimes before_;
  double children_before_ = 0, wall_ = 0, other_ = 0;
};

}  // namespace icube::bench

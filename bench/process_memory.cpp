// The benchmarks' view of their own process; see process_memory.h.
#include "process_memory.h"

#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <fstream>
#include <string>

namespace icube::bench {

namespace {

long page_kib() { return sysconf(_SC_PAGESIZE) / 1024; }

double children_cpu_s() {
  rusage u{};
  getrusage(RUSAGE_CHILDREN, &u);
  return static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) + 1e-6 * static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

}  // namespace

long rss_kib() {
  std::ifstream in("/proc/self/statm");
  long size = 0, resident = 0;
  in >> size >> resident;
  return resident * page_kib();
}

long status_kib(const char* field) {
  std::ifstream in("/proc/self/status");
  std::string line;
  const std::string key = std::string(field) + ":";
  while (std::getline(in, line))
    if (line.rfind(key, 0) == 0) return std::atol(line.c_str() + key.size());
  return 0;
}

bool reset_peak_rss() {
  std::ofstream out("/proc/self/clear_refs");
  out << "5";
  return static_cast<bool>(out.flush());
}

RssSampler::RssSampler() : thread_([this] { loop(); }) {}

RssSampler::~RssSampler() {
  stop_ = true;
  thread_.join();
}

long RssSampler::peak_kib(Clock::time_point t0, Clock::time_point t1) const {
  std::lock_guard<std::mutex> lock(mutex_);
  long peak = 0;
  for (const auto& [t, kib] : samples_)
    if (t >= t0 && t <= t1) peak = std::max(peak, kib);
  return peak;
}

void RssSampler::clear() {
  std::lock_guard<std::mutex> lock(mutex_);
  samples_.clear();
}

void RssSampler::loop() {
  while (!stop_) {
    const long kib = rss_kib();
    {
      std::lock_guard<std::mutex> lock(mutex_);
      samples_.emplace_back(Clock::now(), kib);
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
}

void DisturbanceMeter::start() {
  before_ = cpu_times_now();
  children_before_ = children_cpu_s();
}

void DisturbanceMeter::stop() {
  const CpuTimes after = cpu_times_now();
  const double children = children_cpu_s() - children_before_;
  wall_ += after.wall_s - before_.wall_s;
  other_ += std::max(0.0, other_cpu_seconds(before_, after) - children);
}

double DisturbanceMeter::percent() const {
  return wall_ > 0 ? 100.0 * other_ / (wall_ * std::max(1u, online_cpus())) : 0.0;
}

}  // namespace icube::bench

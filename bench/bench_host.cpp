// Host description and the other-process CPU meter of icube-bench (Linux /proc).
#include "bench_host.h"

#include <sched.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <fstream>
#include <sstream>

namespace icube::bench {

namespace {

double timeval_s(const timeval& t) { return static_cast<double>(t.tv_sec) + static_cast<double>(t.tv_usec) * 1e-6; }

// Busy CPU seconds of all CPUs from the aggregate "cpu" line of /proc/stat
// (everything but idle and iowait); negative when unreadable.
double system_busy_seconds() {
  std::ifstream in("/proc/stat");
  std::string line;
  if (!std::getline(in, line) || line.rfind("cpu ", 0) != 0) return -1.0;
  std::istringstream fields(line.substr(4));
  unsigned long long v[10] = {};
  for (unsigned long long& x : v) fields >> x;
  const unsigned long long idle = v[3] + v[4];
  unsigned long long total = 0;
  for (int i = 0; i < 8; ++i) total += v[i];  // guest time (8, 9) is already in user
  const long ticks = sysconf(_SC_CLK_TCK);
  return ticks > 0 ? static_cast<double>(total - idle) / static_cast<double>(ticks) : -1.0;
}

}  // namespace

std::string env_or_unset(const char* name) {
  const char* v = std::getenv(name);
  return v ? v : "(unset)";
}

std::string cpu_model() {
  std::ifstream in("/proc/cpuinfo");
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("model name", 0) != 0) continue;
    const size_t colon = line.find(':');
    if (colon == std::string::npos) continue;
    const size_t start = line.find_first_not_of(' ', colon + 1);
    return start == std::string::npos ? "unknown" : line.substr(start);
  }
  return "unknown";
}

unsigned online_cpus() {
  cpu_set_t set;
  CPU_ZERO(&set);
  if (sched_getaffinity(0, sizeof(set), &set) != 0) return 0;
  return static_cast<unsigned>(CPU_COUNT(&set));
}

CpuTimes cpu_times_now() {
  CpuTimes t;
  t.system_busy_s = system_busy_seconds();
  rusage u{};
  if (getrusage(RUSAGE_SELF, &u) == 0) t.own_s = timeval_s(u.ru_utime) + timeval_s(u.ru_stime);
  t.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
  return t;
}

double other_cpu_seconds(const CpuTimes& before, const CpuTimes& after) {
  if (before.system_busy_s < 0.0 || after.system_busy_s < 0.0) return 0.0;
  const double others = (after.system_busy_s - before.system_busy_s) - (after.own_s - before.own_s);
  return std::max(0.0, others);
}

}  // namespace icube::bench

// Host facts icube-bench prints with its results (CPU model, usable CPUs,
// environment variables) and a meter of CPU time used by *other* processes
// while a measurement ran, so runs disturbed by a concurrent build show it.
#pragma once

#include <string>

namespace icube::bench {

// The value of environment variable `name`, or "(unset)".
std::string env_or_unset(const char* name);

// The first "model name" of /proc/cpuinfo, or "unknown".
std::string cpu_model();

// CPUs this process may run on (what `nproc` prints); 0 if unknown.
unsigned online_cpus();

// CPU seconds: every CPU's busy time (/proc/stat) and this process's own
// user + system time (getrusage, includes lavapipe's worker threads).
struct CpuTimes {
  double system_busy_s = 0.0;
  double own_s = 0.0;
  double wall_s = 0.0;
};

CpuTimes cpu_times_now();

// CPU seconds other processes used between `before` and `after` (never negative;
// 0 when /proc/stat is unavailable).
double other_cpu_seconds(const CpuTimes& before, const CpuTimes& after);

}  // namespace icube::bench

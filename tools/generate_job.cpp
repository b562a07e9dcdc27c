// The command line's side of the main job; see generate_job.h.
#include "generate_job.h"

#include "progress.h"

#include <signal.h>

#include <cstdio>
#include <cstdlib>
#include <map>
#include <memory>

namespace icube::tools {

void report_on_terminal(pipeline::GenerateArgs& a) {
  auto bars = std::make_shared<std::map<std::string, std::unique_ptr<ProgressBar>>>();
  a.progress = [bars](const std::string& stage, const std::string& unit, size_t done, size_t total) {
    auto& bar = (*bars)[stage];
    if (!bar) bar = std::make_unique<ProgressBar>(stage, unit);
    bar->update(done, total);
  };
  a.log = [](const std::string& line) { std::fprintf(stderr, "%s\n", line.c_str()); };
  // Test hook: ICUBE_GENERATE_KILL_AFTER=STAGE kills the process (SIGKILL, no clean-up) right after STAGE is
  // recorded, as a node failure would.
  a.on_stage_finished = [](const std::string& stage) {
    const char* k = std::getenv("ICUBE_GENERATE_KILL_AFTER");
    if (k && stage == k) raise(SIGKILL);
  };
}

void print_generate_summary(const pipeline::GenerateResult& r, const std::string& scene) {
  std::printf("generate: %s -> %s\n%-10s %10s %14s  %s\n", scene.c_str(), r.package.string().c_str(), "stage",
              "seconds", "peak RSS MiB", "result");
  for (const pipeline::GenerateStage& s : r.stages) {
    if (s.resumed)
      std::printf("%-10s %10s %14s  %s\n", s.name.c_str(), "resumed", "-", s.detail.c_str());
    else
      std::printf("%-10s %10.1f %14.0f  %s\n", s.name.c_str(), s.seconds, s.peak_rss_mib, s.detail.c_str());
  }
  std::printf("%-10s %10.1f\n", "total", r.seconds);
}

}  // namespace icube::tools

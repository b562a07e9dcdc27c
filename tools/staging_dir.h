// A command's output staging folder: PARENT/.NAME.partial-PID, created empty (an
// earlier one of the same name removed, and those of processes that no longer
// run: left by a run killed from outside) and removed again when the command
// fails, unless `keep` is set once its contents have been renamed into place
// (move_into_place does both).
#pragma once

#include <signal.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <system_error>

namespace icube::tools {

struct StagingDir {
  std::filesystem::path path;
  bool keep = false;
  StagingDir(const std::filesystem::path& parent, const std::string& name)
      : path(parent / ("." + name + ".partial-" + std::to_string(getpid()))) {
    std::filesystem::create_directories(parent);
    const std::string stale = "." + name + ".partial-";
    std::error_code ec;
    for (const auto& e : std::filesystem::directory_iterator(parent, ec)) {
      const std::string f = e.path().filename().string();
      if (f.rfind(stale, 0) != 0) continue;
      const long pid = std::strtol(f.c_str() + stale.size(), nullptr, 10);
      if (pid > 0 && kill(static_cast<pid_t>(pid), 0) == -1 && errno == ESRCH) std::filesystem::remove_all(e.path(), ec);
    }
    std::filesystem::remove_all(path);
    std::filesystem::create_directories(path);
  }
  // Replaces `final_dir` by the finished folder (and keeps it from the destructor).
  void move_into_place(const std::filesystem::path& final_dir) {
    if (std::filesystem::exists(final_dir)) std::filesystem::remove_all(final_dir);
    std::filesystem::rename(path, final_dir);
    keep = true;
  }
  StagingDir(const StagingDir&) = delete;
  StagingDir& operator=(const StagingDir&) = delete;
  ~StagingDir() {
    if (keep || path.empty()) return;
    std::error_code ec;
    std::filesystem::remove_all(path, ec);
  }
};

}  // namespace icube::tools

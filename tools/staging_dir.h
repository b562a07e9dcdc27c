// A command's output staging folder: PARENT/.NAME.partial-PID, created empty (an
// earlier one of the same name removed) and removed again when the command fails,
// unless `keep` is set once its contents have been renamed into place.
#pragma once

#include <unistd.h>

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
    std::filesystem::remove_all(path);
    std::filesystem::create_directories(path);
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

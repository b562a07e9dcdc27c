// A package built in stages that a later run can continue: PARENT/.NAME.partial,
// owned by the one process that holds an exclusive flock on PARENT/.NAME.lock
// (the kernel drops it when that process dies, however it dies; flock works
// across hosts on NFSv4 and Lustre mounted with flock). Finished stages are
// recorded in .NAME.partial/.stages.json with the fingerprint of the inputs
// and options; `resume` continues after the last recorded stage when the
// fingerprint matches, and otherwise (or without `resume`) a leftover staging
// folder is removed and the run starts over. commit() renames the folder into
// place. On destruction without commit the folder is kept when a stage
// finished (so --resume can continue after the cause is fixed) and removed
// when none did. Used by `icube generate` (pipeline/generate_package.h).
// Tests: tests/lift/test_generate.cpp (resume after a kill) and tests/pipeline/test_generate_package.cpp.
#pragma once

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

namespace icube::pipeline {

inline constexpr const char* kStagesFile = ".stages.json";

class PackageStaging {
 public:
  // Throws std::runtime_error when another process is building the same package.
  PackageStaging(const std::filesystem::path& final_dir, const std::string& fingerprint, bool resume);
  PackageStaging(const PackageStaging&) = delete;
  PackageStaging& operator=(const PackageStaging&) = delete;
  ~PackageStaging();

  const std::filesystem::path& path() const { return path_; }
  // The detail recorded for a finished stage, or nullptr when it has not finished.
  const std::string* finished(const std::string& stage) const;
  // Stages finished by earlier runs (0 when this run started afresh).
  size_t resumed_stages() const { return resumed_; }
  // Records a finished stage (atomically rewrites the stages file).
  void finish(const std::string& stage, const std::string& detail);
  // Removes the stages file and renames the folder to final_dir (replacing it).
  void commit();

 private:
  void write_stages() const;
  std::filesystem::path final_, path_, lock_path_;
  std::string fingerprint_;
  std::vector<std::pair<std::string, std::string>> done_;
  size_t resumed_ = 0;
  int lock_fd_ = -1;
  bool committed_ = false;
};

}  // namespace icube::pipeline

#include "pipeline/package_staging.h"

#include "scene/atomic_file.h"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <nlohmann/json.hpp>

#include <cstdio>
#include <stdexcept>

namespace icube::pipeline {

namespace fs = std::filesystem;

namespace {

// Opens and exclusively flocks `path`, making sure the file locked is the one
// the path names (a finishing owner unlinks it: a lock on the unlinked file
// would not exclude a newcomer). -1 when another process holds it.
int lock_file(const fs::path& path) {
  for (int attempt = 0; attempt < 100; ++attempt) {
    const int fd = open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (fd < 0) throw std::runtime_error(path.string() + ": cannot create the lock file");
    if (flock(fd, LOCK_EX | LOCK_NB) != 0) {
      close(fd);
      return -1;
    }
    struct stat held {}, named {};
    if (fstat(fd, &held) == 0 && stat(path.c_str(), &named) == 0 && held.st_ino == named.st_ino &&
        held.st_dev == named.st_dev)
      return fd;
    close(fd);  // unlinked under us: lock the new one
  }
  throw std::runtime_error(path.string() + ": cannot lock (the lock file keeps being replaced)");
}

}  // namespace

PackageStaging::PackageStaging(const fs::path& final_dir, const std::string& fingerprint, bool resume)
    : final_(final_dir), fingerprint_(fingerprint) {
  const fs::path parent = final_dir.parent_path();
  const std::string name = final_dir.filename().string();
  fs::create_directories(parent);
  path_ = parent / ("." + name + ".partial");
  lock_path_ = parent / ("." + name + ".lock");
  lock_fd_ = lock_file(lock_path_);
  if (lock_fd_ < 0)
    throw std::runtime_error(final_dir.string() + ": another process is building this package (it holds " +
                             lock_path_.string() + ")");
  std::error_code ec;
  const fs::path stages = path_ / kStagesFile;
  if (resume && fs::is_regular_file(stages, ec)) {
    try {
      const auto j = nlohmann::json::parse(scene::read_file(stages.string()));
      if (j.value("fingerprint", std::string()) == fingerprint_)
        for (const auto& s : j.at("finished")) done_.emplace_back(s.at("stage"), s.at("detail"));
      else
        std::fprintf(stderr, "icube: note: %s: made with other inputs or options; starting over\n", path_.c_str());
    } catch (const std::exception& e) {
      done_.clear();
      std::fprintf(stderr, "icube: note: %s: unreadable (%s); starting over\n", stages.c_str(), e.what());
    }
  }
  resumed_ = done_.size();
  if (done_.empty()) {
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
}

const std::string* PackageStaging::finished(const std::string& stage) const {
  for (const auto& [s, detail] : done_)
    if (s == stage) return &detail;
  return nullptr;
}

void PackageStaging::write_stages() const {
  nlohmann::ordered_json j;
  j["fingerprint"] = fingerprint_;
  j["finished"] = nlohmann::ordered_json::array();
  for (const auto& [s, detail] : done_) j["finished"].push_back({{"stage", s}, {"detail", detail}});
  scene::write_file_atomic((path_ / kStagesFile).string(), j.dump(1) + "\n");
}

void PackageStaging::finish(const std::string& stage, const std::string& detail) {
  done_.emplace_back(stage, detail);
  write_stages();
}

void PackageStaging::commit() {
  fs::remove(path_ / kStagesFile);
  if (fs::exists(final_)) fs::remove_all(final_);
  fs::rename(path_, final_);
  committed_ = true;
}

PackageStaging::~PackageStaging() {
  std::error_code ec;
  if (!committed_ && done_.empty()) fs::remove_all(path_, ec);
  if (!committed_ && !done_.empty())
    std::fprintf(stderr, "icube: note: kept %s after %zu finished stage(s); --resume continues from there\n",
                 path_.c_str(), done_.size());
  if (lock_fd_ >= 0) {
    fs::remove(lock_path_, ec);
    close(lock_fd_);
  }
}

}  // namespace icube::pipeline

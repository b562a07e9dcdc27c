// Running the `icube` binary built next to icube-tests from a test: its
// path, one run with stdout + stderr captured, and a temporary folder.
#pragma once

#include "scene/atomic_file.h"

#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <system_error>
#include <utility>

namespace icube::test {

inline std::filesystem::path icube_binary() {
  std::error_code ec;
  const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe", ec);
  return ec ? std::filesystem::path() : self.parent_path() / "icube";
}

struct CliRun {
  int code = -1;
  std::string output;  // stdout + stderr
};

// Runs `icube ARGS` (ARGS quoted by the caller) with its output in DIR/log.txt.
inline CliRun run_icube(const std::string& args, const std::filesystem::path& dir) {
  const std::filesystem::path log = dir / "log.txt";
  const std::string cmd = icube_binary().string() + " " + args + " > '" + log.string() + "' 2>&1";
  const int status = std::system(cmd.c_str());
  CliRun r;
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.output = std::filesystem::exists(log) ? scene::read_file(log.string()) : std::string();
  return r;
}

// Runs a shell command; its exit status and stdout + stderr.
inline std::pair<int, std::string> run_shell(const std::string& cmd) {
  std::string out;
  FILE* p = popen((cmd + " 2>&1").c_str(), "r");
  if (!p) return {-1, out};
  char buf[512];
  while (std::fgets(buf, sizeof buf, p)) out += buf;
  const int status = pclose(p);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, out};
}

// A python3 that imports `modules` ("numpy", "torch, numpy"): Debian's first (a pyenv or
// venv shim on PATH may lack them), then PATH's; empty when none does.
inline std::string python_with(const std::string& modules) {
  for (const char* py : {"/usr/bin/python3", "python3"})
    if (run_shell(std::string(py) + " -c 'import " + modules + "'").first == 0) return py;
  return {};
}

// An empty folder TMP/icube-<tag>-<pid>, removed with everything in it.
struct TempDir {
  std::filesystem::path path;
  explicit TempDir(const std::string& tag) {
    path = std::filesystem::temp_directory_path() / ("icube-" + tag + "-" + std::to_string(getpid()));
    std::filesystem::remove_all(path);
    std::filesystem::create_directories(path);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path, ec);
  }
};

}  // namespace icube::test

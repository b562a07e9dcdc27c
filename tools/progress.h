// A one-line progress bar on stderr for long commands: redrawn in place on a
// terminal, one line per 10 % otherwise (CI logs), always a final line.
#pragma once

#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <string>

namespace icube::tools {

class ProgressBar {
 public:
  ProgressBar(std::string label, std::string unit) : label_(std::move(label)), unit_(std::move(unit)) {
    tty_ = isatty(fileno(stderr)) != 0;
  }

  void update(size_t done, size_t total) {
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count();
    const double frac = total ? static_cast<double>(done) / static_cast<double>(total) : 1.0;
    const int decile = static_cast<int>(frac * 10.0);
    if (!tty_ && done != total && decile == last_decile_) return;
    last_decile_ = decile;
    constexpr int kWidth = 30;
    const int filled = static_cast<int>(frac * kWidth);
    std::string bar(static_cast<size_t>(filled), '#');
    bar.resize(kWidth, '.');
    const double eta = done ? s / static_cast<double>(done) * static_cast<double>(total - done) : 0.0;
    std::fprintf(stderr, "%s%s [%s] %zu/%zu %s  %.1f s", tty_ ? "\r" : "", label_.c_str(), bar.c_str(), done, total,
                 unit_.c_str(), s);
    if (done < total && done > 0) std::fprintf(stderr, ", ~%.0f s left", eta);
    std::fprintf(stderr, tty_ && done < total ? "   " : "\n");
    std::fflush(stderr);
  }

 private:
  std::string label_, unit_;
  bool tty_ = false;
  int last_decile_ = -1;
  std::chrono::steady_clock::time_point t0_ = std::chrono::steady_clock::now();
};

}  // namespace icube::tools

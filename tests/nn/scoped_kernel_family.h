// Runs a test's networks with one family of network kernels (kernels/nn/kernel_family.h) by setting
// ICUBE_NN_KERNELS for the scope, restoring what was there before.
#pragma once

#include <cstdlib>
#include <optional>
#include <string>

namespace icube::test {

class ScopedKernelFamily {
 public:
  explicit ScopedKernelFamily(const char* family) {
    if (const char* old = std::getenv("ICUBE_NN_KERNELS")) previous_ = old;
    setenv("ICUBE_NN_KERNELS", family, 1);
  }
  ~ScopedKernelFamily() {
    if (previous_) setenv("ICUBE_NN_KERNELS", previous_->c_str(), 1);
    else unsetenv("ICUBE_NN_KERNELS");
  }
  ScopedKernelFamily(const ScopedKernelFamily&) = delete;
  ScopedKernelFamily& operator=(const ScopedKernelFamily&) = delete;

 private:
  std::optional<std::string> previous_;
};

}  // namespace icube::test

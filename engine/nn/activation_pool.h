// The activation memory plan of the GPU networks (UNetGpu, VaeGpu): device
// buffers are pooled; a tensor's buffer returns to the free list when its
// last handle dies during recording and is reused by a later tensor that fits
// (best fit, at most twice the size). Recording order is execution order and
// every op ends with a barrier, so the reuse is safe (write-after-read needs
// only the execution dependency the barriers give). The peak is then near the
// largest live set, not the sum of all layers.
#pragma once

#include "gpu/buffer.h"

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace icube::nn {

class ActivationPool {
 public:
  ActivationPool(gpu::Context& ctx, std::string name) : ctx_(ctx), name_(std::move(name)) {}

  // A buffer of at least `bytes` (>= 4), back in the pool when the last copy of the handle dies.
  std::shared_ptr<gpu::Buffer> take(uint64_t bytes) {
    const uint64_t n = std::max<uint64_t>(bytes, 4);
    gpu::Buffer* b = nullptr;
    const auto it = free_.lower_bound(n);
    if (it != free_.end() && it->first <= 2 * n) {
      b = it->second;
      free_.erase(it);
    } else {
      buffers_.push_back(std::make_unique<gpu::Buffer>(ctx_, n, gpu::MemoryUsage::DeviceLocal, name_));
      b = buffers_.back().get();
      bytes_ += n;
    }
    return std::shared_ptr<gpu::Buffer>(b, [this](gpu::Buffer* r) { free_.emplace(r->size(), r); });
  }
  // Frees every buffer (no handle may be alive); the byte count restarts.
  void reset() {
    free_.clear();
    buffers_.clear();
    bytes_ = 0;
  }
  // Device bytes the pool allocated since the last reset (its peak).
  uint64_t bytes() const { return bytes_; }

 private:
  gpu::Context& ctx_;
  std::string name_;
  std::vector<std::unique_ptr<gpu::Buffer>> buffers_;
  std::multimap<uint64_t, gpu::Buffer*> free_;
  uint64_t bytes_ = 0;
};

}  // namespace icube::nn

// One network's parameters on the device, under the official state-dict names:
// checked against the network's parameter list (name and shape), converted
// and uploaded once. A matrix — a convolution weight [Co, Ci, k, k, k] (k 1 or
// 3), a Conv1d [Co, Ci, 1] or a linear [Co, Ci] — is packed for the conv
// kernels (kernels/nn/conv3d.h's layout, the layout sparse_conv reads too),
// in fp32 or, with f16_matrices, fp16; a 2-D convolution [Co, Ci, kh, kw] is
// packed for kernels/nn/conv2d.h (the same layout over kh x kw taps), always
// fp32; vectors (biases, norm parameters) stay
// fp32 as given. Parameters named in host_only stay on the host (embedding
// tables looked up there). Every network's GPU module (UNetGpu, VaeGpu and
// the ones to come) holds one store, so every weight error reads the same:
// a scene::InputError naming the weights' source and the tensor.
// Tests: tests/nn/test_parameter_store.cpp.
#pragma once

#include "gpu/buffer.h"
#include "kernels/nn/cpu_tensor.h"
#include "nn/param_spec.h"

#include <cstdint>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <vector>

namespace icube::nn {

struct ParameterStoreOptions {
  std::string network = "network";           // in messages: "the UNet", "the VAE"
  std::string source = "the weights given";  // where the weights came from (a file path)
  bool f16_matrices = false;                 // convolution and linear weights stored as fp16
  // Parameters may be absent (a network run in parts: the VAE's decoder without its encoder); a lookup of
  // an absent one names it and `missing_hint`. Without it every listed parameter is required.
  bool partial = false;
  std::string missing_hint;
  std::set<std::string> host_only;
};

class ParameterStore {
 public:
  ParameterStore(gpu::Context& ctx, const std::vector<ParamSpec>& specs, const std::map<std::string, CpuTensor>& weights,
                 ParameterStoreOptions options);
  ParameterStore(const ParameterStore&) = delete;
  ParameterStore& operator=(const ParameterStore&) = delete;

  bool has(const std::string& name) const { return entries_.count(name) != 0; }
  // The device buffer of a parameter (packed for a matrix); throws scene::InputError when absent or host-only.
  const gpu::Buffer& buffer(const std::string& name) const;
  const std::vector<int64_t>& shape(const std::string& name) const;
  // A host_only parameter as given.
  const CpuTensor& host(const std::string& name) const;

  bool f16_matrices() const { return options_.f16_matrices; }
  // Device bytes of every uploaded parameter (packed sizes).
  uint64_t device_bytes() const { return device_bytes_; }

  // Whether a parameter of this shape is stored as a packed matrix, and its kernel edge (1 or 3).
  static bool is_matrix(const std::vector<int64_t>& shape) { return shape.size() >= 2; }
  static uint32_t kernel_edge(const std::vector<int64_t>& shape) { return shape.size() == 5 && shape[2] == 3 ? 3u : 1u; }

 private:
  struct Entry {
    std::vector<int64_t> shape;
    std::unique_ptr<gpu::Buffer> device;
    CpuTensor host;
  };
  const Entry& entry(const std::string& name) const;
  [[noreturn]] void fail(const std::string& name, const std::string& what) const;

  ParameterStoreOptions options_;
  std::map<std::string, Entry> entries_;
  uint64_t device_bytes_ = 0;
};

}  // namespace icube::nn

// The PyTorch side of the network benchmarks (icube-bench-nn,
// icube-bench-sparse): Debian's python3-torch run on the same fixed-seed
// tensors as the GPU kernels, through bench/torch_nn.py (one op per case
// folder) or bench/torch_unet.py (a whole UNet forward). Benchmark-only: the
// icube runtime never runs Python.
#pragma once

#include "kernels/nn/cpu_tensor.h"

#include <nlohmann/json.hpp>

#include <filesystem>
#include <map>
#include <string>
#include <utility>
#include <vector>

namespace icube::bench {

// Runs a shell command; its exit status and stdout + stderr.
std::pair<int, std::string> capture(const std::string& cmd);

void save_npy(const std::string& path, const nn::CpuTensor& t);

struct TorchSide {
  std::string python;  // empty: not run
  int threads = 1, runs = 5, warmup = 1;
  std::filesystem::path dir;

  struct Result {
    bool ok = false;
    double min_ms = 0, median_ms = 0;
    std::vector<float> y;
    std::string error;
  };

  // bench/torch_nn.py on `c` (the op and its arguments) and the named inputs.
  Result run(const nlohmann::json& c, const std::map<std::string, const nn::CpuTensor*>& inputs) const;
};

// bench/torch_unet.py on files: its times and output, or an error.
TorchSide::Result run_torch_unet(const TorchSide& side, const std::string& config, const std::string& weights,
                                 const std::string& x, const std::string& t);

// Debian's python3 first (a pyenv shim on PATH may lack torch); empty when none has torch and numpy.
std::string python_with_torch();

}  // namespace icube::bench

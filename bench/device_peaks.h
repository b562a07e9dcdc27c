// The published peak rates of the GPUs the benchmarks meet, for "what fraction
// of the device's peak does this kernel reach": dense fp32 FMA, dense fp16
// tensor-core math with fp32 accumulation (what the cooperative-matrix kernels
// use; sparsity not counted), and memory bandwidth, from the vendors' data
// sheets. Matched by the Vulkan device name; an unknown device (lavapipe) has
// none, and the benchmarks print "-" for its fractions.
#pragma once

#include <string>

namespace icube::bench {

struct DevicePeak {
  const char* name;                 // as the data sheet names it
  double fp32_tflops;               // dense fp32 (non-tensor)
  double fp16_tensor_tflops;        // dense fp16 tensor, fp32 accumulation
  double memory_gbs;                // device memory bandwidth, GB/s
};

// The peaks of the device called `vulkan_device_name` (VkPhysicalDeviceProperties::deviceName), or nullptr.
const DevicePeak* device_peak(const std::string& vulkan_device_name);

// "12.3%" of `peak` reached by `achieved` (the same unit), or "-" without a peak.
std::string percent_of_peak(double achieved, double peak);
// A rate in GFLOP/s as a share of the device's fp16 tensor peak (`tensor`: the cooperative-matrix kernels) or
// of its fp32 peak; a bandwidth in GB/s as a share of its memory's. "-" when `peak` is nullptr.
std::string percent_of_compute_peak(const DevicePeak* peak, double gflops, bool tensor);
std::string percent_of_memory_peak(const DevicePeak* peak, double gbs);

// One line naming the peaks the fractions refer to (or that there are none), for a benchmark's header.
std::string device_peak_line(const std::string& vulkan_device_name);

}  // namespace icube::bench

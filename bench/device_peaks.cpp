// Published peak rates by device name; see device_peaks.h.
#include "device_peaks.h"

#include <cstdio>

namespace icube::bench {

namespace {

struct Entry {
  const char* match;  // a substring of the Vulkan device name; more specific entries first
  DevicePeak peak;
};

// NVIDIA data sheets (dense rates; the tensor figures with sparsity are twice these). GeForce cards run
// fp16 tensor math with fp32 accumulation at half their fp16-accumulation rate.
constexpr Entry kPeaks[] = {
    {"H200 NVL", {"NVIDIA H200 NVL", 60.0, 835.0, 4800.0}},
    {"H200", {"NVIDIA H200 SXM", 67.0, 989.0, 4800.0}},
    {"H100 NVL", {"NVIDIA H100 NVL", 60.0, 835.0, 3900.0}},
    {"H100 PCIe", {"NVIDIA H100 PCIe", 51.0, 756.0, 2000.0}},
    {"H100", {"NVIDIA H100 SXM", 67.0, 989.0, 3350.0}},
    {"A100-SXM", {"NVIDIA A100 SXM 80GB", 19.5, 312.0, 2039.0}},
    {"A100", {"NVIDIA A100 PCIe 80GB", 19.5, 312.0, 1935.0}},
    {"L40S", {"NVIDIA L40S", 91.6, 362.0, 864.0}},
    {"RTX 4090", {"NVIDIA GeForce RTX 4090", 82.6, 165.2, 1008.0}},
};

}  // namespace

const DevicePeak* device_peak(const std::string& vulkan_device_name) {
  for (const Entry& e : kPeaks)
    if (vulkan_device_name.find(e.match) != std::string::npos) return &e.peak;
  return nullptr;
}

std::string percent_of_peak(double achieved, double peak) {
  if (!(peak > 0.0)) return "-";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f%%", 100.0 * achieved / peak);
  return buf;
}

std::string percent_of_compute_peak(const DevicePeak* peak, double gflops, bool tensor) {
  return percent_of_peak(gflops * 1e-3, peak ? (tensor ? peak->fp16_tensor_tflops : peak->fp32_tflops) : 0.0);
}

std::string percent_of_memory_peak(const DevicePeak* peak, double gbs) {
  return percent_of_peak(gbs, peak ? peak->memory_gbs : 0.0);
}

std::string device_peak_line(const std::string& vulkan_device_name) {
  const DevicePeak* p = device_peak(vulkan_device_name);
  if (!p) return "peaks: none known for '" + vulkan_device_name + "' (no fractions of peak)";
  char buf[224];
  std::snprintf(buf, sizeof buf,
                "peaks (%s data sheet, dense): fp32 %.1f TFLOP/s, fp16 tensor (fp32 accumulation) %.0f TFLOP/s, "
                "memory %.0f GB/s",
                p->name, p->fp32_tflops, p->fp16_tensor_tflops, p->memory_gbs);
  return buf;
}

}  // namespace icube::bench

// libFuzzer target: bytes -> nn::SafetensorsFile::from_bytes (header JSON,
// dtypes, shapes, offsets), then every tensor read as float32 and scanned for
// non-finite values, so a header that passes validation but lies about its
// ranges shows up as an AddressSanitizer report. Bad input must be a one-line
// scene::InputError. Seeds: tests/fuzz/corpus/safetensors/.
#include "nn/safetensors.h"
#include "scene/input_error.h"

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  try {
    const icube::nn::SafetensorsFile f =
        icube::nn::SafetensorsFile::from_bytes(std::string(reinterpret_cast<const char*>(data), size), "fuzz.safetensors");
    for (const icube::nn::TensorInfo& t : f.tensors()) {
      if (t.numel() > (uint64_t{1} << 24)) continue;  // in range by validation; just too slow to convert
      const std::vector<float> v = f.to_f32(t);
      (void)f.first_non_finite(t);
      if (v.size() != t.numel() || f.find(t.name) != &t) std::abort();
    }
  } catch (const icube::scene::InputError& e) {
    if (std::string(e.what()).find('\n') != std::string::npos) std::abort();
  }
  return 0;
}

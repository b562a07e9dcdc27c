// The `.safetensors` weight format (huggingface/safetensors): an 8-byte
// little-endian header length N, N bytes of JSON
//   {"__metadata__": {"k": "v", ...},                     (optional, strings only)
//    "<name>": {"dtype": "F32", "shape": [d0, ...], "data_offsets": [begin, end]}, ...}
// then the data section; offsets are relative to it, little-endian, C order.
//
// SafetensorsFile memory-maps the file (a copy for from_bytes) and validates
// everything before any tensor is read, as the reference implementation does:
// the header length fits the file and is at most 100 MB; the JSON is one object
// without duplicate keys; every tensor has exactly dtype / shape / data_offsets;
// dtype is F32, F16 or BF16 (the network layer's storage types) or I64, I32,
// U8, BOOL (a reference case's indices and masks; weights refuse them), others
// are an error naming the tensor; shape entries are non-negative integers and
// numel x dtype size = end - begin without overflow; ranges are inside the data
// section, do not overlap, and cover it with no gap (sorted by begin, each
// starts where the previous ended, the last ends at the file's end). Every
// failure is a scene::InputError naming the file and the first tensor (or the
// byte) at fault.
//
// Tensors keep the header's order by name (the JSON object is unordered);
// to_f32 converts F16 (IEEE binary16, subnormals, inf and NaN kept) and BF16
// (the upper half of a binary32) exactly. write_safetensors writes the same
// format (tensors in the order given, contiguous), atomically, for tests and
// tools. Tests: tests/nn/test_safetensors.cpp; fuzz: tests/fuzz/fuzz_safetensors.cpp.
#pragma once

#include "kernels/nn/float16.h"

#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace icube::nn {

// Floats for weights; integers and booleans for the indices and masks of reference cases.
enum class DType { F32, F16, BF16, I64, I32, U8, BOOL };

size_t dtype_size(DType t);
const char* dtype_name(DType t);  // "F32", "F16", "BF16", "I64", ...
bool dtype_is_float(DType t);     // F32, F16, BF16

// half_to_float, float_to_half, bf16_to_float, float_to_bf16: nn/float16.h.

struct TensorInfo {
  std::string name;
  DType dtype = DType::F32;
  std::vector<int64_t> shape;
  uint64_t begin = 0, end = 0;  // byte range in the data section
  uint64_t numel() const;
  std::string shape_text() const;  // "[32, 16, 3, 3, 3]"
};

class SafetensorsFile {
 public:
  // Maps and validates `path`; throws scene::InputError.
  explicit SafetensorsFile(const std::string& path);
  // Validates an in-memory copy; `name` stands for the file in messages.
  static SafetensorsFile from_bytes(std::string bytes, const std::string& name);

  SafetensorsFile(SafetensorsFile&&) noexcept;
  SafetensorsFile& operator=(SafetensorsFile&&) noexcept;
  ~SafetensorsFile();

  const std::string& path() const { return path_; }
  const std::vector<TensorInfo>& tensors() const { return tensors_; }  // sorted by name
  const std::map<std::string, std::string>& metadata() const { return metadata_; }
  const TensorInfo* find(std::string_view name) const;
  uint64_t header_bytes() const { return header_bytes_; }
  uint64_t data_bytes() const { return data_size_; }

  // The tensor's raw little-endian bytes.
  std::span<const uint8_t> bytes(const TensorInfo& t) const;
  // Values as float32 (F16/BF16 converted exactly; integers rounded to float).
  std::vector<float> to_f32(const TensorInfo& t) const;
  // Integer and boolean tensors as int64 (floats throw std::invalid_argument).
  std::vector<int64_t> to_i64(const TensorInfo& t) const;
  // Index of the first NaN or infinity, or -1 (always -1 for integers).
  int64_t first_non_finite(const TensorInfo& t) const;

 private:
  SafetensorsFile() = default;
  void parse();

  std::string path_;
  std::string owned_;            // from_bytes
  const uint8_t* base_ = nullptr;  // whole file
  size_t size_ = 0;
  void* map_ = nullptr;          // mmap'ed region, or nullptr
  uint64_t header_bytes_ = 0, data_size_ = 0;
  const uint8_t* data_ = nullptr;
  std::vector<TensorInfo> tensors_;
  std::map<std::string, std::string> metadata_;
};

struct TensorToWrite {
  std::string name;
  DType dtype = DType::F32;
  std::vector<int64_t> shape;
  std::vector<uint8_t> bytes;  // numel x dtype size, little-endian
};

// F32 tensor helper for writers.
TensorToWrite f32_tensor(std::string name, std::vector<int64_t> shape, const std::vector<float>& values);
TensorToWrite i32_tensor(std::string name, std::vector<int64_t> shape, const std::vector<int32_t>& values);
TensorToWrite u8_tensor(std::string name, std::vector<int64_t> shape, const std::vector<uint8_t>& values);

// The file's bytes (header padded with spaces to a multiple of 8, as the
// reference writer does).
std::string safetensors_bytes(const std::vector<TensorToWrite>& tensors,
                              const std::map<std::string, std::string>& metadata = {});
void write_safetensors(const std::string& path, const std::vector<TensorToWrite>& tensors,
                       const std::map<std::string, std::string>& metadata = {});

}  // namespace icube::nn

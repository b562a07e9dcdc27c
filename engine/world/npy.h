// NumPy .npy arrays (docs: ../shared/reference/formats.md §8): read v1/v2/v3,
// write v1 (v2 when the header passes 65,535 bytes), little-endian C order,
// dtypes <f4 <f8 |u1 <u2 <i4 <u4 <i8, any rank. Fortran order, big-endian
// and other dtypes are rejected with scene::InputError. Writes are atomic.
// Tests: tests/world/test_world_npy.cpp.
#pragma once

#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

namespace icube::world {

enum class NpyDtype { F4, F8, U1, U2, I4, U4, I8 };

size_t npy_dtype_size(NpyDtype t);
const char* npy_dtype_descr(NpyDtype t);  // "<f4", "|u1", ...

template <class T>
constexpr NpyDtype npy_dtype_of() {
  if constexpr (std::is_same_v<T, float>) return NpyDtype::F4;
  else if constexpr (std::is_same_v<T, double>) return NpyDtype::F8;
  else if constexpr (std::is_same_v<T, uint8_t>) return NpyDtype::U1;
  else if constexpr (std::is_same_v<T, uint16_t>) return NpyDtype::U2;
  else if constexpr (std::is_same_v<T, int32_t>) return NpyDtype::I4;
  else if constexpr (std::is_same_v<T, uint32_t>) return NpyDtype::U4;
  else {
    static_assert(std::is_same_v<T, int64_t>, "unsupported npy element type");
    return NpyDtype::I8;
  }
}

struct NpyArray {
  NpyDtype dtype = NpyDtype::F4;
  std::vector<uint64_t> shape;  // empty = scalar (one element)
  std::vector<uint8_t> data;    // element_count() * npy_dtype_size(dtype) bytes, little-endian, C order

  uint64_t element_count() const;
  // Element i converted to double (int64 beyond 2^53 rounds).
  double as_double(size_t i) const;

  template <class T>
  static NpyArray make(std::vector<uint64_t> shape, const std::vector<T>& values) {
    NpyArray a;
    a.dtype = npy_dtype_of<T>();
    a.shape = std::move(shape);
    if (a.element_count() != values.size()) throw std::invalid_argument("NpyArray::make: shape does not match values");
    a.data.resize(values.size() * sizeof(T));
    if (!values.empty()) std::memcpy(a.data.data(), values.data(), a.data.size());
    return a;
  }
  template <class T>
  std::vector<T> values() const {
    if (npy_dtype_of<T>() != dtype) throw std::invalid_argument("NpyArray::values: dtype differs");
    std::vector<T> v(data.size() / sizeof(T));
    if (!v.empty()) std::memcpy(v.data(), data.data(), data.size());
    return v;
  }
};

// `name` is for error messages only.
NpyArray npy_from_bytes(std::string_view bytes, const std::string& name);
std::string npy_to_bytes(const NpyArray& a);

NpyArray read_npy(const std::string& path);
void write_npy(const std::string& path, const NpyArray& a);

}  // namespace icube::world

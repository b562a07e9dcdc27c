// .npy read/write: round trips for every dtype and several ranks (v1 and v2
// headers), numpy-written bytes, and malformed headers as InputErrors.
#include <doctest/doctest.h>

#include "scene/input_error.h"
#include "world/npy.h"

#include <cstring>
#include <filesystem>
#include <string>
#include <type_traits>

#include <unistd.h>

using namespace icube;
using world::NpyArray;

namespace {

template <class T>
void round_trip(std::vector<uint64_t> shape) {
  uint64_t n = 1;
  for (uint64_t d : shape) n *= d;
  std::vector<T> v(n);
  for (uint64_t i = 0; i < n; ++i) {
    T val = static_cast<T>(i * 37 % 251);
    if constexpr (std::is_floating_point_v<T>) val = static_cast<T>(val + static_cast<T>(0.25));
    if constexpr (std::is_signed_v<T>)
      if (i % 2) val = static_cast<T>(-val);
    v[i] = val;
  }
  const NpyArray a = NpyArray::make<T>(shape, v);
  const std::string bytes = world::npy_to_bytes(a);
  CHECK((bytes.size() - a.data.size()) % 64 == 0);
  const NpyArray b = world::npy_from_bytes(bytes, "rt.npy");
  CHECK(b.dtype == a.dtype);
  CHECK(b.shape == shape);
  CHECK(b.values<T>() == v);
  CHECK(world::npy_to_bytes(b) == bytes);
}

std::string npy_error(const std::string& bytes) {
  try {
    world::npy_from_bytes(bytes, "bad.npy");
  } catch (const scene::InputError& e) {
    return e.what();
  }
  return "";
}

std::string v1(const std::string& dict, const std::string& data) {
  std::string h = dict;
  while ((10 + h.size() + 1) % 64) h += ' ';
  h += '\n';
  std::string out("\x93NUMPY\x01\x00", 8);
  out += static_cast<char>(h.size() & 0xff);
  out += static_cast<char>(h.size() >> 8);
  return out + h + data;
}

}  // namespace

TEST_CASE("npy: round trip of every dtype and rank") {
  for (const auto& shape : std::vector<std::vector<uint64_t>>{{}, {1}, {7}, {3, 4}, {2, 3, 4}, {2, 1, 3, 2}, {0, 5}}) {
    CAPTURE(shape.size());
    round_trip<float>(shape);
    round_trip<double>(shape);
    round_trip<uint8_t>(shape);
    round_trip<uint16_t>(shape);
    round_trip<int32_t>(shape);
    round_trip<uint32_t>(shape);
    round_trip<int64_t>(shape);
  }
  // A rank-30000 shape of ones needs a header over 64 KiB: written as v2.
  std::vector<uint64_t> tall(30000, 1);
  const std::string bytes = world::npy_to_bytes(NpyArray::make<float>(tall, {2.5f}));
  CHECK(bytes[6] == 2);
  CHECK(world::npy_from_bytes(bytes, "v2.npy").values<float>() == std::vector<float>{2.5f});
}

TEST_CASE("npy: reads numpy's own header forms") {
  // As numpy 1.x writes np.arange(3, dtype='<u2'): key order and trailing comma as numpy has them.
  const std::string data("\x00\x00\x01\x00\x02\x00", 6);
  NpyArray a = world::npy_from_bytes(v1("{'descr': '<u2', 'fortran_order': False, 'shape': (3,), }", data), "a");
  CHECK(a.values<uint16_t>() == std::vector<uint16_t>{0, 1, 2});
  a = world::npy_from_bytes(v1("{\"shape\": (1, 3), \"fortran_order\": False, \"descr\": \"<u2\"}", data), "b");
  CHECK(a.shape == std::vector<uint64_t>{1, 3});
  a = world::npy_from_bytes(v1("{'descr': '|u1', 'fortran_order': False, 'shape': (), }", "\x07"), "c");
  CHECK(a.shape.empty());
  CHECK(a.as_double(0) == 7.0);
  // Written files are atomic and readable.
  const auto path = std::filesystem::temp_directory_path() / ("icube_npy_" + std::to_string(::getpid()) + ".npy");
  world::write_npy(path.string(), NpyArray::make<int64_t>({2}, {-5, 1LL << 40}));
  CHECK(world::read_npy(path.string()).values<int64_t>() == std::vector<int64_t>{-5, 1LL << 40});
  std::filesystem::remove(path);
}

TEST_CASE("npy: malformed files are InputErrors") {
  const std::string f4(4, '\0');
  CHECK(npy_error("hello").find("not a .npy file") != std::string::npos);
  CHECK(npy_error(v1("{'descr': '>f4', 'fortran_order': False, 'shape': (1,), }", f4)).find("big-endian") !=
        std::string::npos);
  CHECK(npy_error(v1("{'descr': '<f4', 'fortran_order': True, 'shape': (1,), }", f4)).find("Fortran") !=
        std::string::npos);
  CHECK(npy_error(v1("{'descr': '|O', 'fortran_order': False, 'shape': (1,), }", f4)).find("unsupported dtype") !=
        std::string::npos);
  CHECK(npy_error(v1("{'descr': '<f4', 'fortran_order': False, 'shape': (2,), }", f4)).find("does not match") !=
        std::string::npos);
  CHECK(npy_error(v1("{'descr': '<f4', 'fortran_order': False, 'shape': (1,), }", f4 + "x")).find("does not match") !=
        std::string::npos);
  CHECK(npy_error(v1("{'descr': '<f4', 'fortran_order': False, 'shape': (4294967296, 4294967296, 16), }", f4))
            .find("does not match") != std::string::npos);
  CHECK(npy_error(v1("{'descr': '<f4', 'fortran_order': False, 'shape': (1,) ", f4)).find("npy header") !=
        std::string::npos);
  CHECK(npy_error(v1("{'descr': '<f4', 'shape': (1,), }", f4)).find("lacks") != std::string::npos);
  CHECK(npy_error(v1("{'descr': '<f4', 'fortran_order': False, 'shape': (-1,), }", f4)).find("non-negative") !=
        std::string::npos);
  CHECK(npy_error(v1("{'descr': '<f4', 'fortran_order': Maybe, 'shape': (1,), }", f4)).find("True or False") !=
        std::string::npos);
  std::string longhdr = v1("{'descr': '<f4', 'fortran_order': False, 'shape': (1,), }", f4);
  longhdr[8] = '\xff';
  longhdr[9] = '\xff';
  CHECK(npy_error(longhdr).find("exceeds the file") != std::string::npos);
  std::string v9 = longhdr;
  v9[6] = 9;
  CHECK(npy_error(v9).find("unsupported .npy version 9") != std::string::npos);
}

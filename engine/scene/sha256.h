// SHA-256 (FIPS 180-4) of bytes and of files, as lowercase hex: the file
// hashes of a package manifest. Tests: tests/scene/test_sha256.cpp (the FIPS
// examples and a file read in chunks).
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <string_view>

namespace icube::scene {

class Sha256 {
 public:
  Sha256();
  void update(const void* data, size_t bytes);
  std::array<uint8_t, 32> digest();  // finishes; the object must not be updated afterwards
  std::string hex();

 private:
  void block(const uint8_t* p);
  std::array<uint32_t, 8> h_;
  std::array<uint8_t, 64> buf_{};
  size_t buf_len_ = 0;
  uint64_t total_ = 0;
};

std::string sha256_hex(std::string_view bytes);
// Throws std::runtime_error "PATH: cannot read" when the file cannot be read.
std::string sha256_file(const std::string& path);

}  // namespace icube::scene

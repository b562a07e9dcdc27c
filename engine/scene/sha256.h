// SHA-256 (FIPS 180-4) of bytes and of files, as lowercase hex: the file
// hashes of a package manifest. Computed by OpenSSL's libcrypto (EVP; the
// SHA extensions where the CPU has them): ~5x the hand-written transform this
// replaced on package hashes (bench/README.md, "SHA-256"). Tests:
// tests/scene/test_sha256.cpp (the FIPS examples and a file read in chunks).
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>

struct evp_md_ctx_st;  // OpenSSL's EVP_MD_CTX, kept out of this header

namespace icube::scene {

class Sha256 {
 public:
  Sha256();
  ~Sha256();
  Sha256(Sha256&&) noexcept;
  Sha256& operator=(Sha256&&) noexcept;
  void update(const void* data, size_t bytes);
  std::array<uint8_t, 32> digest();  // finishes; the object must not be updated afterwards
  std::string hex();

 private:
  struct Free {
    void operator()(evp_md_ctx_st* c) const;
  };
  std::unique_ptr<evp_md_ctx_st, Free> ctx_;
};

std::string sha256_hex(std::string_view bytes);
// Throws std::runtime_error "PATH: cannot read" when the file cannot be read.
std::string sha256_file(const std::string& path);

}  // namespace icube::scene

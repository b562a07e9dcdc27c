// Uncompressed POSIX ustar archives, as InfiniCube's webdataset tars
// (<clip>.NNNNNN.<suffix> members, conventions §11).
//
// Writer: one 512-byte header per member (name <= 100 bytes, or split into
// prefix/name at a '/' up to 255 bytes), mode 0644, uid/gid 0, octal size,
// mtime 0 (byte-identical archives for identical inputs), typeflag '0',
// magic "ustar\0" version "00", checksum = sum of the header bytes with the
// checksum field as 8 spaces, written as 6 octal digits, NUL, space. Data is
// padded to 512 bytes; the archive ends with two zero blocks. Members keep the
// order they were added in. Members larger than 8 GiB - 1 are rejected.
// Reader (tests and round trips): plain ustar/v7 regular files only; bad
// checksums, truncated data and non-octal fields throw std::runtime_error.
// Tests: tests/render/test_guidance_buffers.cpp.
#pragma once

#include <string>
#include <string_view>
#include <vector>

namespace icube::render {

struct TarMember {
  std::string name;
  std::string data;
};

class TarWriter {
 public:
  // Throws std::invalid_argument for an empty, too long or non-ASCII name.
  void add(std::string name, std::string data);
  size_t size() const { return members_.size(); }
  // The archive bytes.
  std::string bytes() const;
  // bytes(), written atomically (scene::write_file_atomic).
  void write(const std::string& path) const;

 private:
  std::vector<TarMember> members_;
};

std::string tar_bytes(const std::vector<TarMember>& members);
std::vector<TarMember> parse_tar(std::string_view bytes);

}  // namespace icube::render

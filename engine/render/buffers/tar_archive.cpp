// ustar writer and reader; see tar_archive.h.
#include "render/buffers/tar_archive.h"

#include "scene/atomic_file.h"

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <stdexcept>

namespace icube::render {

namespace {

constexpr size_t kBlock = 512;
constexpr uint64_t kMaxSize = (uint64_t{1} << 33) - 1;  // 11 octal digits

// `value` as `digits` octal digits followed by a NUL, into field[0 .. digits].
void put_octal(char* field, size_t digits, uint64_t value) {
  for (size_t i = digits; i-- > 0;) {
    field[i] = static_cast<char>('0' + (value & 7u));
    value >>= 3;
  }
  field[digits] = '\0';
}

// ustar name split: (prefix, name) with name <= 100 and prefix <= 155 bytes, cut at a '/'.
std::pair<std::string, std::string> split_name(const std::string& full) {
  if (full.size() <= 100) return {std::string(), full};
  const size_t cut = full.rfind('/', 155);
  if (cut == std::string::npos || cut == 0 || full.size() - cut - 1 > 100)
    throw std::invalid_argument("tar: member name '" + full + "' is too long for ustar");
  return {full.substr(0, cut), full.substr(cut + 1)};
}

void check_name(const std::string& name) {
  if (name.empty()) throw std::invalid_argument("tar: empty member name");
  for (char c : name)
    if (static_cast<unsigned char>(c) < 32 || static_cast<unsigned char>(c) > 126)
      throw std::invalid_argument("tar: member name '" + name + "' has a non-printable or non-ASCII character");
  split_name(name);
}

void write_header(std::string& out, const TarMember& m) {
  char h[kBlock];
  std::memset(h, 0, kBlock);
  const auto [prefix, name] = split_name(m.name);
  if (m.data.size() > kMaxSize) throw std::invalid_argument("tar: member '" + m.name + "' is larger than 8 GiB");
  std::memcpy(h + 0, name.data(), name.size());
  put_octal(h + 100, 7, 0644);               // mode
  put_octal(h + 108, 7, 0);                  // uid
  put_octal(h + 116, 7, 0);                  // gid
  put_octal(h + 124, 11, m.data.size());     // size
  put_octal(h + 136, 11, 0);                 // mtime: 0 for deterministic archives
  std::memset(h + 148, ' ', 8);              // checksum placeholder
  h[156] = '0';                              // regular file
  std::memcpy(h + 257, "ustar", 6);          // magic "ustar\0"
  h[263] = '0';
  h[264] = '0';                              // version "00"
  std::memcpy(h + 345, prefix.data(), prefix.size());
  unsigned sum = 0;
  for (size_t i = 0; i < kBlock; ++i) sum += static_cast<unsigned char>(h[i]);
  put_octal(h + 148, 6, sum);
  h[155] = ' ';
  out.append(h, kBlock);
}

uint64_t parse_octal(const char* field, size_t len, const char* what) {
  uint64_t v = 0;
  size_t i = 0;
  while (i < len && field[i] == ' ') ++i;
  bool any = false;
  for (; i < len && field[i] != '\0' && field[i] != ' '; ++i) {
    if (field[i] < '0' || field[i] > '7') throw std::runtime_error(std::string("tar: non-octal ") + what + " field");
    v = v * 8 + static_cast<uint64_t>(field[i] - '0');
    any = true;
  }
  if (!any) throw std::runtime_error(std::string("tar: empty ") + what + " field");
  return v;
}

std::string field_string(const char* f, size_t len) {
  size_t n = 0;
  while (n < len && f[n] != '\0') ++n;
  return std::string(f, n);
}

}  // namespace

void TarWriter::add(std::string name, std::string data) {
  check_name(name);
  members_.push_back({std::move(name), std::move(data)});
}

std::string TarWriter::bytes() const { return tar_bytes(members_); }

void TarWriter::write(const std::string& path) const { scene::write_file_atomic(path, bytes()); }

std::string tar_bytes(const std::vector<TarMember>& members) {
  size_t total = 2 * kBlock;
  for (const TarMember& m : members) total += kBlock + (m.data.size() + kBlock - 1) / kBlock * kBlock;
  std::string out;
  out.reserve(total);
  for (const TarMember& m : members) {
    check_name(m.name);
    write_header(out, m);
    out.append(m.data);
    out.append((kBlock - m.data.size() % kBlock) % kBlock, '\0');
  }
  out.append(2 * kBlock, '\0');
  return out;
}

std::vector<TarMember> parse_tar(std::string_view bytes) {
  std::vector<TarMember> out;
  size_t pos = 0;
  while (true) {
    if (pos + kBlock > bytes.size()) throw std::runtime_error("tar: truncated archive (no end-of-archive blocks)");
    const char* h = bytes.data() + pos;
    bool zero = true;
    for (size_t i = 0; i < kBlock && zero; ++i) zero = h[i] == '\0';
    if (zero) break;
    unsigned sum = 0;
    for (size_t i = 0; i < kBlock; ++i) sum += (i >= 148 && i < 156) ? 32u : static_cast<unsigned char>(h[i]);
    if (parse_octal(h + 148, 8, "checksum") != sum)
      throw std::runtime_error("tar: header checksum mismatch at byte " + std::to_string(pos));
    const char type = h[156];
    if (type != '0' && type != '\0') throw std::runtime_error("tar: only regular files are supported");
    const uint64_t size = parse_octal(h + 124, 12, "size");
    std::string name = field_string(h, 100);
    if (std::memcmp(h + 257, "ustar", 5) == 0) {
      const std::string prefix = field_string(h + 345, 155);
      if (!prefix.empty()) name = prefix + "/" + name;
    }
    pos += kBlock;
    if (size > bytes.size() - pos) throw std::runtime_error("tar: member '" + name + "' is truncated");
    out.push_back({name, std::string(bytes.substr(pos, static_cast<size_t>(size)))});
    pos += (static_cast<size_t>(size) + kBlock - 1) / kBlock * kBlock;
  }
  return out;
}

}  // namespace icube::render

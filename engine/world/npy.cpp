// .npy reader (a strict parser of the header's Python dict literal) and writer.
#include "world/npy.h"

#include "scene/atomic_file.h"
#include "scene/input_error.h"

#include <bit>
#include <cctype>
#include <optional>

namespace icube::world {

namespace {

constexpr char kMagic[6] = {'\x93', 'N', 'U', 'M', 'P', 'Y'};

struct DtypeInfo {
  const char* descr;
  NpyDtype type;
};
constexpr DtypeInfo kDtypes[] = {{"<f4", NpyDtype::F4}, {"<f8", NpyDtype::F8}, {"|u1", NpyDtype::U1},
                                 {"<u1", NpyDtype::U1}, {"<u2", NpyDtype::U2}, {"<i4", NpyDtype::I4},
                                 {"<u4", NpyDtype::U4}, {"<i8", NpyDtype::I8}};

// Parses {'descr': '<f4', 'fortran_order': False, 'shape': (3, 4), } in any key order.
class HeaderParser {
 public:
  HeaderParser(std::string_view text, const std::string& name) : s_(text), name_(name) {}

  void parse(std::string& descr, bool& fortran, std::vector<uint64_t>& shape) {
    bool have_descr = false, have_fortran = false, have_shape = false;
    ws();
    expect('{');
    for (;;) {
      ws();
      if (peek() == '}') break;
      const std::string key = string_literal();
      ws();
      expect(':');
      ws();
      if (key == "descr") {
        descr = string_literal();
        have_descr = true;
      } else if (key == "fortran_order") {
        if (word("True")) fortran = true;
        else if (word("False")) fortran = false;
        else fail("'fortran_order' must be True or False");
        have_fortran = true;
      } else if (key == "shape") {
        shape = tuple();
        have_shape = true;
      } else {
        fail("unexpected header key '" + key + "'");
      }
      ws();
      if (peek() == ',') {
        ++pos_;
        continue;
      }
      ws();
      if (peek() != '}') fail("expected ',' or '}' in the header");
    }
    ++pos_;
    if (!have_descr || !have_fortran || !have_shape)
      fail("header lacks 'descr', 'fortran_order' or 'shape'");
    ws();
    if (pos_ != s_.size()) fail("unexpected text after the header dict");
  }

 private:
  [[noreturn]] void fail(const std::string& what) const {
    throw scene::InputError(name_, "npy header", what);
  }
  char peek() const { return pos_ < s_.size() ? s_[pos_] : '\0'; }
  void ws() {
    while (pos_ < s_.size() && (s_[pos_] == ' ' || s_[pos_] == '\n' || s_[pos_] == '\t' || s_[pos_] == '\r')) ++pos_;
  }
  void expect(char c) {
    if (peek() != c) fail(std::string("expected '") + c + "'");
    ++pos_;
  }
  bool word(std::string_view w) {
    if (s_.substr(pos_, w.size()) != w) return false;
    pos_ += w.size();
    return true;
  }
  std::string string_literal() {
    const char q = peek();
    if (q != '\'' && q != '"') fail("expected a quoted string");
    const size_t start = ++pos_;
    while (pos_ < s_.size() && s_[pos_] != q) ++pos_;
    if (pos_ >= s_.size()) fail("unterminated string");
    return std::string(s_.substr(start, pos_++ - start));
  }
  std::vector<uint64_t> tuple() {
    std::vector<uint64_t> dims;
    expect('(');
    for (;;) {
      ws();
      if (peek() == ')') break;
      if (!std::isdigit(static_cast<unsigned char>(peek()))) fail("shape entries must be non-negative integers");
      uint64_t v = 0;
      while (std::isdigit(static_cast<unsigned char>(peek()))) {
        const uint64_t d = static_cast<uint64_t>(peek() - '0');
        if (v > (UINT64_MAX - d) / 10) fail("shape entry overflows");
        v = v * 10 + d;
        ++pos_;
      }
      dims.push_back(v);
      ws();
      if (peek() == ',') {
        ++pos_;
        continue;
      }
      if (peek() != ')') fail("expected ',' or ')' in 'shape'");
    }
    ++pos_;
    return dims;
  }
  std::string_view s_;
  const std::string& name_;
  size_t pos_ = 0;
};

}  // namespace

size_t npy_dtype_size(NpyDtype t) {
  switch (t) {
    case NpyDtype::U1: return 1;
    case NpyDtype::U2: return 2;
    case NpyDtype::F4:
    case NpyDtype::I4:
    case NpyDtype::U4: return 4;
    case NpyDtype::F8:
    case NpyDtype::I8: return 8;
  }
  return 0;
}

const char* npy_dtype_descr(NpyDtype t) {
  switch (t) {
    case NpyDtype::F4: return "<f4";
    case NpyDtype::F8: return "<f8";
    case NpyDtype::U1: return "|u1";
    case NpyDtype::U2: return "<u2";
    case NpyDtype::I4: return "<i4";
    case NpyDtype::U4: return "<u4";
    case NpyDtype::I8: return "<i8";
  }
  return "?";
}

uint64_t NpyArray::element_count() const {
  uint64_t n = 1;
  for (uint64_t d : shape) n *= d;
  return n;
}

double NpyArray::as_double(size_t i) const {
  const uint8_t* p = data.data() + i * npy_dtype_size(dtype);
  switch (dtype) {
    case NpyDtype::F4: { float v; std::memcpy(&v, p, 4); return static_cast<double>(v); }
    case NpyDtype::F8: { double v; std::memcpy(&v, p, 8); return v; }
    case NpyDtype::U1: return p[0];
    case NpyDtype::U2: { uint16_t v; std::memcpy(&v, p, 2); return v; }
    case NpyDtype::I4: { int32_t v; std::memcpy(&v, p, 4); return v; }
    case NpyDtype::U4: { uint32_t v; std::memcpy(&v, p, 4); return v; }
    case NpyDtype::I8: { int64_t v; std::memcpy(&v, p, 8); return static_cast<double>(v); }
  }
  return 0.0;
}

NpyArray npy_from_bytes(std::string_view bytes, const std::string& name) {
  static_assert(std::endian::native == std::endian::little, "the npy reader assumes a little-endian host");
  if (bytes.size() < 10 || std::memcmp(bytes.data(), kMagic, 6) != 0)
    throw scene::InputError(name, "byte 0", "not a .npy file (missing \\x93NUMPY magic)");
  const int major = static_cast<uint8_t>(bytes[6]);
  size_t header_len = 0, header_start = 0;
  if (major == 1) {
    header_len = static_cast<uint8_t>(bytes[8]) | static_cast<size_t>(static_cast<uint8_t>(bytes[9])) << 8;
    header_start = 10;
  } else if (major == 2 || major == 3) {
    if (bytes.size() < 12) throw scene::InputError(name, "byte 8", "truncated header length");
    uint32_t len;
    std::memcpy(&len, bytes.data() + 8, 4);
    header_len = len;
    header_start = 12;
  } else {
    throw scene::InputError(name, "byte 6", "unsupported .npy version " + std::to_string(major) + "." +
                                                std::to_string(static_cast<uint8_t>(bytes[7])));
  }
  if (header_len > bytes.size() - header_start)
    throw scene::InputError(name, "byte 8", "header length " + std::to_string(header_len) + " exceeds the file");
  std::string descr;
  bool fortran = false;
  NpyArray a;
  HeaderParser(bytes.substr(header_start, header_len), name).parse(descr, fortran, a.shape);
  if (fortran) throw scene::InputError(name, "npy header", "Fortran-order arrays are not supported (use C order)");
  std::optional<NpyDtype> type;
  for (const DtypeInfo& d : kDtypes)
    if (descr == d.descr) type = d.type;
  if (!type) {
    if (!descr.empty() && descr[0] == '>')
      throw scene::InputError(name, "npy header", "big-endian dtype '" + descr + "' is not supported");
    throw scene::InputError(name, "npy header",
                            "unsupported dtype '" + descr + "' (supported: <f4 <f8 |u1 <u2 <i4 <u4 <i8)");
  }
  a.dtype = *type;
  const size_t data_start = header_start + header_len;
  const uint64_t available = bytes.size() - data_start;
  const uint64_t esize = npy_dtype_size(a.dtype);
  uint64_t n = 1;  // bounded by the file size before anything is allocated
  for (uint64_t d : a.shape) {
    if (d != 0 && n > available / esize / d) {
      n = UINT64_MAX;
      break;
    }
    n *= d;
  }
  if (n == UINT64_MAX || n * esize != available)
    throw scene::InputError(name, "byte " + std::to_string(data_start),
                            "data size " + std::to_string(available) + " bytes does not match the shape and dtype");
  a.data.assign(reinterpret_cast<const uint8_t*>(bytes.data() + data_start),
                reinterpret_cast<const uint8_t*>(bytes.data() + bytes.size()));
  return a;
}

std::string npy_to_bytes(const NpyArray& a) {
  if (a.data.size() != a.element_count() * npy_dtype_size(a.dtype))
    throw std::invalid_argument("npy_to_bytes: data size does not match the shape");
  std::string dict = std::string("{'descr': '") + npy_dtype_descr(a.dtype) + "', 'fortran_order': False, 'shape': (";
  for (size_t i = 0; i < a.shape.size(); ++i) dict += (i ? ", " : "") + std::to_string(a.shape[i]);
  if (a.shape.size() == 1) dict += ",";
  dict += "), }";
  const bool v2 = dict.size() + 1 + 10 > 65535;
  const size_t prefix = v2 ? 12 : 10;
  const size_t total = (prefix + dict.size() + 1 + 63) / 64 * 64;
  dict.append(total - prefix - dict.size() - 1, ' ');
  dict += '\n';
  std::string out(kMagic, 6);
  out += static_cast<char>(v2 ? 2 : 1);
  out += '\0';
  const size_t hl = dict.size();
  out += static_cast<char>(hl & 0xff);
  out += static_cast<char>((hl >> 8) & 0xff);
  if (v2) {
    out += static_cast<char>((hl >> 16) & 0xff);
    out += static_cast<char>((hl >> 24) & 0xff);
  }
  out += dict;
  out.append(reinterpret_cast<const char*>(a.data.data()), a.data.size());
  return out;
}

NpyArray read_npy(const std::string& path) { return npy_from_bytes(scene::read_file(path), path); }

void write_npy(const std::string& path, const NpyArray& a) { scene::write_file_atomic(path, npy_to_bytes(a)); }

}  // namespace icube::world

// PLY header parser, count bounds and body cursor; see ply_reader.h.
#include "world/ply_reader.h"

#include "scene/input_error.h"

#include <algorithm>
#include <bit>
#include <charconv>
#include <cstdlib>
#include <cstring>

namespace icube::world {
namespace {

using scene::InputError;

bool ws(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\f' || c == '\v'; }

std::vector<std::string_view> split(std::string_view line) {
  std::vector<std::string_view> out;
  size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && ws(line[i])) ++i;
    size_t j = i;
    while (j < line.size() && !ws(line[j])) ++j;
    if (j > i) out.push_back(line.substr(i, j - i));
    i = j;
  }
  return out;
}

template <typename T>
bool parse_full(std::string_view s, T& out) {
  if (!s.empty() && s[0] == '+') s.remove_prefix(1);
  auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), out);
  return ec == std::errc() && p == s.data() + s.size();
}

bool strtod_full(std::string_view s, double& out) {
  const std::string tok(s);
  char* end = nullptr;
  out = std::strtod(tok.c_str(), &end);
  return end == tok.c_str() + tok.size();
}

std::string quote(std::string_view s) { return "'" + std::string(s.substr(0, 40)) + "'"; }

void parse_format(const std::vector<std::string_view>& tok, PlyHeader& h, const std::string& name,
                  const std::string& where) {
  if (tok.size() != 3) throw InputError(name, where, "bad format line");
  if (tok[1] == "ascii") h.format = PlyFormat::Ascii;
  else if (tok[1] == "binary_little_endian") h.format = PlyFormat::BinaryLE;
  else if (tok[1] == "binary_big_endian") h.format = PlyFormat::BinaryBE;
  else throw InputError(name, where, "unknown format " + quote(tok[1]));
}

void parse_element(const std::vector<std::string_view>& tok, PlyHeader& h, const std::string& name,
                   const std::string& where) {
  int64_t count = 0;
  if (tok.size() != 3 || !parse_full(tok[2], count) || count < 0) throw InputError(name, where, "bad element line");
  h.elements.push_back({std::string(tok[1]), static_cast<uint64_t>(count), {}});
}

void parse_property(const std::vector<std::string_view>& tok, PlyHeader& h, const std::string& name,
                    const std::string& where) {
  if (h.elements.empty()) throw InputError(name, where, "property before any element");
  PlyProperty p;
  if (tok.size() == 5 && tok[1] == "list") {
    const auto c = ply_type_from_name(tok[2]), v = ply_type_from_name(tok[3]);
    if (!c || !v || !ply_type_is_int(*c)) throw InputError(name, where, "bad list property types");
    p.is_list = true;
    p.count_type = *c;
    p.type = *v;
    p.name = tok[4];
  } else if (tok.size() == 3) {
    const auto v = ply_type_from_name(tok[1]);
    if (!v) throw InputError(name, where, "unknown property type " + quote(tok[1]));
    p.type = *v;
    p.name = tok[2];
  } else {
    throw InputError(name, where, "bad property line");
  }
  h.elements.back().props.push_back(p);
}

// Handles one header line after the magic; returns true at end_header.
bool parse_header_line(const std::vector<std::string_view>& tok, PlyHeader& h, size_t line_no,
                       const std::string& name) {
  const std::string where = "header line " + std::to_string(line_no);
  if (tok.empty() || tok[0] == "comment" || tok[0] == "obj_info") return false;
  if (tok[0] == "end_header") return true;
  if (tok[0] == "format") {
    parse_format(tok, h, name, where);
    h.format_line = line_no;
  } else if (tok[0] == "element") {
    parse_element(tok, h, name, where);
  } else if (tok[0] == "property") {
    parse_property(tok, h, name, where);
  } else {
    throw InputError(name, where, "unknown header keyword " + quote(tok[0]));
  }
  return false;
}

template <typename T>
double decode_as(const unsigned char* b) {
  T v;
  std::memcpy(&v, b, sizeof v);
  return static_cast<double>(v);
}

}  // namespace

std::optional<PlyType> ply_type_from_name(std::string_view s) {
  static const std::pair<const char*, PlyType> kTypes[] = {
      {"char", PlyType::I8},   {"int8", PlyType::I8},     {"uchar", PlyType::U8},   {"uint8", PlyType::U8},
      {"short", PlyType::I16}, {"int16", PlyType::I16},   {"ushort", PlyType::U16}, {"uint16", PlyType::U16},
      {"int", PlyType::I32},   {"int32", PlyType::I32},   {"uint", PlyType::U32},   {"uint32", PlyType::U32},
      {"float", PlyType::F32}, {"float32", PlyType::F32}, {"double", PlyType::F64}, {"float64", PlyType::F64}};
  for (const auto& [n, v] : kTypes)
    if (s == n) return v;
  return std::nullopt;
}

size_t ply_type_size(PlyType t) {
  switch (t) {
    case PlyType::I8: case PlyType::U8: return 1;
    case PlyType::I16: case PlyType::U16: return 2;
    case PlyType::I32: case PlyType::U32: case PlyType::F32: return 4;
    case PlyType::F64: return 8;
  }
  return 1;
}

bool ply_type_is_int(PlyType t) { return t != PlyType::F32 && t != PlyType::F64; }

int PlyElement::scalar_index(std::string_view prop) const {
  for (size_t k = 0; k < props.size(); ++k)
    if (!props[k].is_list && props[k].name == prop) return static_cast<int>(k);
  return -1;
}

int PlyElement::list_index(std::string_view prop) const {
  for (size_t k = 0; k < props.size(); ++k)
    if (props[k].is_list && props[k].name == prop) return static_cast<int>(k);
  return -1;
}

const PlyElement* PlyHeader::find(std::string_view element) const {
  for (const auto& e : elements)
    if (e.name == element) return &e;
  return nullptr;
}

PlyHeader parse_ply_header(std::string_view bytes, const std::string& name) {
  PlyHeader h;
  size_t pos = 0, line_no = 0;
  bool ended = false;
  while (pos < bytes.size() && !ended) {
    const size_t nl = bytes.find('\n', pos);
    if (nl == std::string_view::npos) break;
    const auto tok = split(bytes.substr(pos, nl - pos));
    pos = nl + 1;
    ++line_no;
    if (line_no == 1) {
      if (tok.size() != 1 || tok[0] != "ply")
        throw InputError(name, "header line 1", "not a PLY file (no 'ply' magic)");
      continue;
    }
    ended = parse_header_line(tok, h, line_no, name);
  }
  if (!ended) throw InputError(name, "header", "no end_header");
  if (h.format_line == 0) throw InputError(name, "header", "no format line");
  h.body_offset = pos;
  h.header_lines = line_no;
  return h;
}

bool ply_rows_fit(const PlyElement& e, PlyFormat format, size_t body_size) {
  uint64_t min_size = 0;
  for (const auto& p : e.props)
    min_size += format == PlyFormat::Ascii ? 2 : ply_type_size(p.is_list ? p.count_type : p.type);
  return min_size == 0 || e.count <= body_size / min_size + 1;
}

PlyCursor::PlyCursor(std::string_view body, PlyFormat format, size_t body_offset, size_t first_line, AsciiInts ints)
    : body_(body), format_(format), base_(body_offset), line_(first_line), ints_(ints) {}

PlyCursor::Status PlyCursor::next(PlyType t, double& out) {
  return format_ == PlyFormat::Ascii ? next_ascii(t, out) : next_binary(t, out);
}

PlyCursor::Status PlyCursor::next_ascii(PlyType t, double& out) {
  while (pos_ < body_.size() && ws(body_[pos_])) {
    if (body_[pos_] == '\n') ++line_;
    ++pos_;
  }
  size_t end = pos_;
  while (end < body_.size() && !ws(body_[end])) ++end;
  if (end == pos_) return Status::End;
  token_ = body_.substr(pos_, end - pos_);
  pos_ = end;
  if (ints_ == AsciiInts::Lenient) return strtod_full(token_, out) ? Status::Ok : Status::BadNumber;
  if (ply_type_is_int(t)) {
    int64_t v = 0;
    if (!parse_full(token_, v)) return Status::BadInteger;
    out = static_cast<double>(v);
    return Status::Ok;
  }
  return parse_full(token_, out) ? Status::Ok : Status::BadNumber;
}

PlyCursor::Status PlyCursor::next_binary(PlyType t, double& out) {
  const size_t n = ply_type_size(t);
  if (n > body_.size() - pos_) return Status::End;
  unsigned char b[8];
  std::memcpy(b, body_.data() + pos_, n);
  pos_ += n;
  if ((format_ == PlyFormat::BinaryBE) == (std::endian::native == std::endian::little)) std::reverse(b, b + n);
  switch (t) {
    case PlyType::I8: out = decode_as<int8_t>(b); break;
    case PlyType::U8: out = b[0]; break;
    case PlyType::I16: out = decode_as<int16_t>(b); break;
    case PlyType::U16: out = decode_as<uint16_t>(b); break;
    case PlyType::I32: out = decode_as<int32_t>(b); break;
    case PlyType::U32: out = decode_as<uint32_t>(b); break;
    case PlyType::F32: out = decode_as<float>(b); break;
    case PlyType::F64: out = decode_as<double>(b); break;
  }
  return Status::Ok;
}

}  // namespace icube::world

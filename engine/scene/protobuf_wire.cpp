// Bounds-checked protobuf wire reader (see protobuf_wire.h). Every read is
// checked against the end of the current message before it happens; nothing
// is allocated except error text and the caller's output vectors, which grow
// by at most one element per input byte.
#include "scene/protobuf_wire.h"

#include "scene/input_error.h"

#include <bit>
#include <cstring>

namespace icube::scene {
namespace {

uint64_t load_le(const uint8_t* p, size_t n) {
  uint64_t v = 0;
  for (size_t i = 0; i < n; ++i) v |= uint64_t(p[i]) << (8 * i);
  return v;
}

std::string field_label(uint32_t field, WireType t) {
  return "field " + std::to_string(field) + " (" + wire_type_name(t) + ")";
}

}  // namespace

const char* wire_type_name(WireType t) {
  switch (t) {
    case WireType::Varint: return "VARINT";
    case WireType::I64: return "I64";
    case WireType::Len: return "LEN";
    case WireType::StartGroup: return "SGROUP";
    case WireType::EndGroup: return "EGROUP";
    case WireType::I32: return "I32";
  }
  return "?";
}

WireReader::WireReader(const uint8_t* data, size_t size, const WireOrigin& origin)
    : data_(data), size_(size), origin_(&origin) {}

WireReader::WireReader(const WireReader& parent, const uint8_t* data, size_t size, const char* name, size_t index)
    : data_(data),
      size_(size),
      origin_(parent.origin_),
      parent_(&parent),
      name_(name),
      index_(index),
      depth_(parent.depth_ + 1),
      root_pos_(parent.root_pos_ + parent.value_pos_) {}

std::string WireReader::path() const {
  // Appends one piece at a time (GCC 12 warns falsely on chained operator+ here).
  std::string p = parent_ ? parent_->path() : origin_->root_name;
  if (parent_) p.append(".").append(name_);
  if (index_ != kNoIndex) p.append("[").append(std::to_string(index_)).append("]");
  return p;
}

std::string WireReader::where_at(uint64_t offset) const {
  std::string w = origin_->where.empty() ? std::string() : origin_->where + " ";
  return w + "at byte " + std::to_string(offset) + ", in " + path();
}

void WireReader::fail_at(size_t pos, const std::string& what) const {
  throw InputError(origin_->file, where_at(origin_->base + root_pos_ + pos), what);
}

void WireReader::fail(const std::string& what) const {
  if (field_ == 0) fail_at(0, what);
  fail_at(key_pos_, field_label(field_, type_) + ": " + what);
}

uint64_t WireReader::read_varint(size_t& pos, size_t end, const char* what) const {
  const size_t start = pos;
  uint64_t v = 0;
  for (size_t i = 0; i < kMaxVarintBytes; ++i) {
    if (pos >= end)
      fail_at(start, std::string(what) + ": varint runs past the end (" + std::to_string(end - start) + " bytes left)");
    const uint8_t b = data_[pos++];
    v |= uint64_t(b & 0x7fu) << (7 * i);  // bits past 64 in the 10th byte are dropped
    if (!(b & 0x80u)) return v;
  }
  fail_at(start, std::string(what) + ": varint longer than 10 bytes");
}

void WireReader::skip_group(size_t& pos) {
  // Iterative: a stack of open group field numbers, bounded by the depth limit.
  uint32_t open[kMaxWireDepth];
  int depth = 0;
  open[depth++] = field_;
  while (depth > 0) {
    const size_t key_pos = pos;
    if (pos >= size_) fail_at(key_pos_, field_label(field_, type_) + ": group is not closed before the end of the message");
    const uint64_t key = read_varint(pos, size_, "key in group");
    const uint32_t t = uint32_t(key & 7u);
    const uint64_t f = key >> 3;
    if (f == 0 || f > 0x1fffffffu) fail_at(key_pos, "invalid field number " + std::to_string(f) + " in group");
    switch (t) {
      case 0: read_varint(pos, size_, "value in group"); break;
      case 1:
      case 5: {
        const size_t n = t == 1 ? 8 : 4;
        if (size_ - pos < n) fail_at(key_pos, "fixed-size value in group runs past the end of the message");
        pos += n;
        break;
      }
      case 2: {
        const uint64_t len = read_varint(pos, size_, "length in group");
        if (len > size_ - pos)
          fail_at(key_pos, "length " + std::to_string(len) + " in group runs past the end of the message (" +
                               std::to_string(size_ - pos) + " bytes left)");
        pos += size_t(len);
        break;
      }
      case 3:
        if (depth_ + depth >= kMaxWireDepth)
          fail_at(key_pos, "groups nested deeper than " + std::to_string(kMaxWireDepth));
        open[depth++] = uint32_t(f);
        break;
      case 4:
        if (open[depth - 1] != f)
          fail_at(key_pos, "end-group for field " + std::to_string(f) + " closes group " +
                               std::to_string(open[depth - 1]));
        --depth;
        break;
      default: fail_at(key_pos, "invalid wire type " + std::to_string(t));
    }
  }
}

bool WireReader::next() {
  if (pos_ >= size_) return false;
  key_pos_ = pos_;
  field_ = 0;  // so that errors in the key are reported at the key without a field label
  const uint64_t key = read_varint(pos_, size_, "field key");
  const uint32_t t = uint32_t(key & 7u);
  const uint64_t f = key >> 3;
  if (t == 6 || t == 7) fail_at(key_pos_, "invalid wire type " + std::to_string(t) + " (field " + std::to_string(f) + ")");
  if (f == 0 || f > 0x1fffffffu) fail_at(key_pos_, "invalid field number " + std::to_string(f));
  field_ = uint32_t(f);
  type_ = static_cast<WireType>(t);
  switch (type_) {
    case WireType::Varint: value_ = read_varint(pos_, size_, "value"); break;
    case WireType::I64:
    case WireType::I32: {
      const size_t n = type_ == WireType::I64 ? 8 : 4;
      if (size_ - pos_ < n)
        fail(std::to_string(n) + "-byte value runs past the end of the message (" + std::to_string(size_ - pos_) +
             " bytes left)");
      value_ = load_le(data_ + pos_, n);
      pos_ += n;
      break;
    }
    case WireType::Len: {
      const uint64_t len = read_varint(pos_, size_, "length");
      if (len > size_ - pos_)
        fail("length " + std::to_string(len) + " runs past the end of the message (" + std::to_string(size_ - pos_) +
             " bytes left)");
      value_pos_ = pos_;
      value_size_ = size_t(len);
      pos_ += size_t(len);
      break;
    }
    case WireType::StartGroup: skip_group(pos_); break;
    case WireType::EndGroup: fail("end-group without a matching start-group");
  }
  return true;
}

void WireReader::expect(WireType t) const {
  if (type_ != t) fail(std::string("wrong wire type, expected ") + wire_type_name(t));
}

uint64_t WireReader::varint() const {
  expect(WireType::Varint);
  return value_;
}

double WireReader::float64() const {
  expect(WireType::I64);
  return std::bit_cast<double>(value_);
}

float WireReader::float32() const {
  expect(WireType::I32);
  return std::bit_cast<float>(static_cast<uint32_t>(value_));
}

std::string_view WireReader::bytes() const {
  expect(WireType::Len);
  return {reinterpret_cast<const char*>(data_ + value_pos_), value_size_};
}

WireReader WireReader::message(const char* name, size_t index) const {
  expect(WireType::Len);
  if (depth_ + 1 > kMaxWireDepth) fail("messages nested deeper than " + std::to_string(kMaxWireDepth));
  return WireReader(*this, data_ + value_pos_, value_size_, name, index);
}

void WireReader::repeated_double(std::vector<double>& out) const {
  if (type_ == WireType::I64) {
    out.push_back(float64());
    return;
  }
  expect(WireType::Len);
  if (value_size_ % 8 != 0)
    fail("packed doubles: length " + std::to_string(value_size_) + " is not a multiple of 8");
  for (size_t i = 0; i < value_size_; i += 8)
    out.push_back(std::bit_cast<double>(load_le(data_ + value_pos_ + i, 8)));
}

void WireReader::repeated_int64(std::vector<int64_t>& out) const {
  if (type_ == WireType::Varint) {
    out.push_back(int64());
    return;
  }
  expect(WireType::Len);
  const size_t end = value_pos_ + value_size_;  // within size_, checked by next()
  size_t pos = value_pos_;
  while (pos < end) out.push_back(static_cast<int64_t>(read_varint(pos, end, "packed varint")));
}

}  // namespace icube::scene

// A small bounds-checked reader for the protobuf wire format (no schema, no
// generated code). ../shared/reference/formats.md §1.2 has the rules.
//
// Usage: a WireReader walks the fields of one message in file order:
//   while (r.next()) switch (r.field()) { case 1: x = r.float64(); break; ... }
// Fields the caller does not ask for are skipped by wire type (groups
// included, nested up to kMaxWireDepth); fields may come in any order and
// repeat (a repeated scalar may be packed or not: repeated_double/int64
// accept both). Typed accessors check the wire type of the current field.
//
// Conventions:
// - Varints have at most 10 bytes; extra high bits of the 10th are dropped
//   and int32 fields keep the low 32 bits, as protobuf does.
// - Every error is an InputError, one line:
//     "<file>: <where> at byte <offset>, in <path>: <what>"
//   where <where> comes from WireOrigin (e.g. "record 3"), <offset> is
//   WireOrigin::base + the position in the root buffer of the offending
//   bytes, and <path> names the message, e.g. "Scenario.tracks[4].states[7]".
// - A WireReader for a sub-message keeps a pointer to its parent (for the
//   path), so the parent must outlive it; use them as nested locals.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace icube::scene {

enum class WireType : uint8_t { Varint = 0, I64 = 1, Len = 2, StartGroup = 3, EndGroup = 4, I32 = 5 };

const char* wire_type_name(WireType t);

// Nesting limit for sub-messages and skipped groups.
inline constexpr int kMaxWireDepth = 64;
// Longest varint (a 64-bit value, e.g. a negative int32/int64).
inline constexpr size_t kMaxVarintBytes = 10;

// Names the buffer a root reader walks, for error messages.
struct WireOrigin {
  std::string file;
  std::string where;               // e.g. "record 3"
  uint64_t base = 0;               // file offset of the root buffer's first byte
  std::string root_name = "message";  // e.g. "Scenario"
};

class WireReader {
 public:
  static constexpr size_t kNoIndex = ~size_t(0);

  // A reader for a root message; `origin` must outlive it.
  WireReader(const uint8_t* data, size_t size, const WireOrigin& origin);

  // Reads the next field's key and value (skipping groups); false at the end.
  bool next();

  uint32_t field() const { return field_; }
  WireType type() const { return type_; }

  // The current field's value; each throws unless the wire type matches.
  uint64_t varint() const;
  int64_t int64() const { return static_cast<int64_t>(varint()); }
  int32_t int32() const { return static_cast<int32_t>(static_cast<uint32_t>(varint())); }
  bool boolean() const { return varint() != 0; }
  double float64() const;
  float float32() const;
  std::string_view bytes() const;

  // The current LEN field as a sub-message named `name` (and `index` for a
  // repeated field) in error paths. Throws past kMaxWireDepth.
  WireReader message(const char* name, size_t index = kNoIndex) const;

  // Appends the current field, unpacked (one I64 / Varint) or packed (LEN).
  void repeated_double(std::vector<double>& out) const;
  void repeated_int64(std::vector<int64_t>& out) const;

  // Throws unless the current field has wire type `t`.
  void expect(WireType t) const;

  // InputError at the current field (or at this message when before the first).
  [[noreturn]] void fail(const std::string& what) const;
  // The "<where> at byte <offset>, in <path>" part of errors at absolute offset `offset`.
  std::string where_at(uint64_t offset) const;

  std::string path() const;
  uint64_t start_offset() const { return origin_->base + root_pos_; }  // this message's first byte
  uint64_t field_offset() const { return origin_->base + root_pos_ + key_pos_; }
  const WireOrigin& origin() const { return *origin_; }

 private:
  WireReader(const WireReader& parent, const uint8_t* data, size_t size, const char* name, size_t index);
  [[noreturn]] void fail_at(size_t pos, const std::string& what) const;
  uint64_t read_varint(size_t& pos, size_t end, const char* what) const;
  void skip_group(size_t& pos);

  const uint8_t* data_ = nullptr;
  size_t size_ = 0;
  size_t pos_ = 0;
  const WireOrigin* origin_ = nullptr;
  const WireReader* parent_ = nullptr;
  const char* name_ = nullptr;
  size_t index_ = kNoIndex;
  int depth_ = 0;
  uint64_t root_pos_ = 0;  // position of data_[0] in the root buffer

  // The current field.
  size_t key_pos_ = 0;
  uint32_t field_ = 0;
  WireType type_ = WireType::Varint;
  uint64_t value_ = 0;        // Varint value, or I64/I32 bits
  size_t value_pos_ = 0;      // LEN payload position
  size_t value_size_ = 0;     // LEN payload size
};

}  // namespace icube::scene

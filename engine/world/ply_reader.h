// Shared PLY reading for point clouds (point_import) and meshes (triangle_mesh).
//
// parse_ply_header reads "ply" ... "end_header": format ascii /
// binary_little_endian / binary_big_endian, elements with counts, scalar and
// list properties of every PLY scalar type (char..double and the aliases
// int8..float64); comment and obj_info lines are skipped. Header errors are
// scene::InputError naming "header line N" (or "header").
//
// ply_rows_fit bounds an element's count by the body size before anything is
// allocated. PlyCursor reads body values one at a time, ascii tokens or binary
// of either byte order, and reports a status instead of throwing, so each
// caller keeps its own one-line error messages (row numbers, byte offsets,
// ascii line numbers from line()).
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace icube::world {

enum class PlyType : uint8_t { I8, U8, I16, U16, I32, U32, F32, F64 };
enum class PlyFormat { Ascii, BinaryLE, BinaryBE };

// "char"/"int8" ... "double"/"float64"; nullopt for anything else.
std::optional<PlyType> ply_type_from_name(std::string_view name);
size_t ply_type_size(PlyType t);
bool ply_type_is_int(PlyType t);

struct PlyProperty {
  std::string name;
  PlyType type = PlyType::F32;  // the item type for lists
  bool is_list = false;
  PlyType count_type = PlyType::U8;
};

struct PlyElement {
  std::string name;
  uint64_t count = 0;
  std::vector<PlyProperty> props;
  // Index of the first scalar (is_list == false) / list property called `prop`, or -1.
  int scalar_index(std::string_view prop) const;
  int list_index(std::string_view prop) const;
};

struct PlyHeader {
  PlyFormat format = PlyFormat::Ascii;
  size_t format_line = 0;  // header line of the "format" keyword
  std::vector<PlyElement> elements;
  size_t body_offset = 0;  // first byte after the end_header line
  size_t header_lines = 0; // lines up to and including end_header
  const PlyElement* find(std::string_view element) const;
};

// Throws scene::InputError(name, "header line N" or "header", ...).
PlyHeader parse_ply_header(std::string_view bytes, const std::string& name);

// False when `e.count` rows of the smallest possible size cannot fit in `body_size` bytes.
bool ply_rows_fit(const PlyElement& e, PlyFormat format, size_t body_size);

// Reads the values of a PLY body in order.
class PlyCursor {
 public:
  enum class Status { Ok, End, BadInteger, BadNumber };
  // Typed: integer-typed ascii values must be integers, others std::from_chars numbers.
  // Lenient: every ascii value is read whole by std::strtod, whatever its type.
  enum class AsciiInts { Typed, Lenient };

  PlyCursor(std::string_view body, PlyFormat format, size_t body_offset, size_t first_line,
            AsciiInts ints = AsciiInts::Typed);

  Status next(PlyType t, double& out);
  bool ascii() const { return format_ == PlyFormat::Ascii; }
  std::string_view token() const { return token_; }        // the last ascii token read
  size_t byte() const { return base_ + pos_; }              // offset in the whole file
  size_t line() const { return line_; }                     // current ascii line number

 private:
  Status next_ascii(PlyType t, double& out);
  Status next_binary(PlyType t, double& out);

  std::string_view body_;
  PlyFormat format_;
  size_t base_;
  size_t line_;
  AsciiInts ints_;
  size_t pos_ = 0;
  std::string_view token_;
};

}  // namespace icube::world

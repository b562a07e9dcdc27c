// XML helpers for the OpenDRIVE parser: local-name matching, strict number
// parsing and error messages that carry the element's XML line number.
//
// Conventions: elements are matched by local name ("odr:road" and "road" with
// a default xmlns both match "road"); attributes by exact name. Numbers are
// parsed with std::from_chars after trimming blanks and one leading '+';
// anything else (trailing text, NaN, Inf) is an InputError of the form
// "<file>: <where> (line N): attribute 'x' ...".
#pragma once

#include "scene/input_error.h"

#include <pugixml.hpp>

#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

namespace icube::scene::odr {

// True when the element's name without any "prefix:" equals `local`.
bool has_local_name(const pugi::xml_node& node, std::string_view local);

// First child element with that local name (empty node when none).
pugi::xml_node child_named(const pugi::xml_node& node, std::string_view local);

// All child elements with that local name, in document order.
std::vector<pugi::xml_node> children_named(const pugi::xml_node& node, std::string_view local);

// Concatenated text and CDATA of an element, trimmed.
std::string element_text(const pugi::xml_node& node);

std::string trim(std::string_view s);

class XmlSource {
 public:
  XmlSource(const char* data, size_t size, std::string file, Diagnostics* diag);

  const std::string& file() const { return file_; }
  // 1-based line of a byte offset into the buffer (clamped).
  int line_of_offset(ptrdiff_t offset) const;
  int line_of(const pugi::xml_node& node) const { return line_of_offset(node.offset_debug()); }

  // "<where> (line N)" for messages.
  std::string at(const pugi::xml_node& node, const std::string& where) const;
  [[noreturn]] void fail(const pugi::xml_node& node, const std::string& where, const std::string& what) const;
  void warn(const pugi::xml_node& node, const std::string& where, const std::string& what) const;

  // Required / optional attributes. Numbers must be finite and, unless stated, |v| <= 1e300.
  double number(const pugi::xml_node& node, const char* name, const std::string& where) const;
  double number_or(const pugi::xml_node& node, const char* name, double fallback, const std::string& where) const;
  int integer(const pugi::xml_node& node, const char* name, const std::string& where) const;
  std::string string(const pugi::xml_node& node, const char* name, const std::string& where) const;
  std::string string_or(const pugi::xml_node& node, const char* name, const std::string& fallback) const;
  bool boolean_or(const pugi::xml_node& node, const char* name, bool fallback, const std::string& where) const;

 private:
  std::string file_;
  Diagnostics* diag_;
  std::vector<size_t> newlines_;  // byte offsets of '\n'
};

}  // namespace icube::scene::odr

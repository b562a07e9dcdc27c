// XML helpers for the OpenDRIVE parser (see xodr_xml.h).
#include "scene/opendrive/xodr_xml.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <cstring>

namespace icube::scene::odr {

namespace {

std::string_view local_part(const char* name) {
  std::string_view n(name);
  const size_t colon = n.rfind(':');
  return colon == std::string_view::npos ? n : n.substr(colon + 1);
}

bool is_blank(char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r'; }

// Quotes an attribute value for a message, shortened to 40 characters.
std::string quoted_value(std::string_view v) {
  std::string out(v.substr(0, 40));
  for (char& c : out)
    if (static_cast<unsigned char>(c) < 0x20) c = '?';
  return "'" + out + (v.size() > 40 ? "...'" : "'");
}

}  // namespace

bool has_local_name(const pugi::xml_node& node, std::string_view local) {
  return node.type() == pugi::node_element && local_part(node.name()) == local;
}

pugi::xml_node child_named(const pugi::xml_node& node, std::string_view local) {
  for (pugi::xml_node c = node.first_child(); c; c = c.next_sibling())
    if (has_local_name(c, local)) return c;
  return {};
}

std::vector<pugi::xml_node> children_named(const pugi::xml_node& node, std::string_view local) {
  std::vector<pugi::xml_node> out;
  for (pugi::xml_node c = node.first_child(); c; c = c.next_sibling())
    if (has_local_name(c, local)) out.push_back(c);
  return out;
}

std::string trim(std::string_view s) {
  size_t b = 0, e = s.size();
  while (b < e && is_blank(s[b])) ++b;
  while (e > b && is_blank(s[e - 1])) --e;
  return std::string(s.substr(b, e - b));
}

std::string element_text(const pugi::xml_node& node) {
  std::string text;
  for (pugi::xml_node c = node.first_child(); c; c = c.next_sibling())
    if (c.type() == pugi::node_pcdata || c.type() == pugi::node_cdata) text += c.value();
  return trim(text);
}

XmlSource::XmlSource(const char* data, size_t size, std::string file, Diagnostics* diag)
    : file_(std::move(file)), diag_(diag) {
  const char* p = data;
  const char* end = data + size;
  while (p < end) {
    const void* nl = std::memchr(p, '\n', static_cast<size_t>(end - p));
    if (!nl) break;
    const char* q = static_cast<const char*>(nl);
    newlines_.push_back(static_cast<size_t>(q - data));
    p = q + 1;
  }
}

int XmlSource::line_of_offset(ptrdiff_t offset) const {
  if (offset < 0) return 0;
  const auto it = std::lower_bound(newlines_.begin(), newlines_.end(), static_cast<size_t>(offset));
  return static_cast<int>(it - newlines_.begin()) + 1;
}

std::string XmlSource::at(const pugi::xml_node& node, const std::string& where) const {
  const int line = line_of(node);
  if (line <= 0) return where;
  return (where.empty() ? std::string() : where + " ") + "(line " + std::to_string(line) + ")";
}

void XmlSource::fail(const pugi::xml_node& node, const std::string& where, const std::string& what) const {
  throw InputError(file_, at(node, where), what);
}

void XmlSource::warn(const pugi::xml_node& node, const std::string& where, const std::string& what) const {
  if (diag_) diag_->warn(file_, at(node, where), what);
}

double XmlSource::number(const pugi::xml_node& node, const char* name, const std::string& where) const {
  const pugi::xml_attribute a = node.attribute(name);
  if (!a) fail(node, where, std::string("missing attribute '") + name + "'");
  std::string_view v(a.value());
  size_t b = 0, e = v.size();
  while (b < e && is_blank(v[b])) ++b;
  while (e > b && is_blank(v[e - 1])) --e;
  std::string_view body = v.substr(b, e - b);
  if (!body.empty() && body[0] == '+') body.remove_prefix(1);
  double out = 0.0;
  const auto [ptr, ec] = std::from_chars(body.data(), body.data() + body.size(), out);
  if (body.empty() || ptr != body.data() + body.size() ||
      (ec != std::errc() && ec != std::errc::result_out_of_range))
    fail(node, where, std::string("attribute '") + name + "' is not a number: " + quoted_value(v));
  if (ec == std::errc::result_out_of_range) {
    // from_chars leaves `out` untouched on overflow and underflow alike; underflow reads as 0.
    const std::string copy(body);
    const double approx = std::strtod(copy.c_str(), nullptr);
    if (std::fabs(approx) >= 1.0) fail(node, where, std::string("attribute '") + name + "' is out of range: " + quoted_value(v));
    out = 0.0;
  }
  if (std::isnan(out)) fail(node, where, std::string("attribute '") + name + "' is NaN");
  if (std::isinf(out)) fail(node, where, std::string("attribute '") + name + "' is infinite");
  if (std::fabs(out) > 1e300) fail(node, where, std::string("attribute '") + name + "' is out of range: " + quoted_value(v));
  return out;
}

double XmlSource::number_or(const pugi::xml_node& node, const char* name, double fallback,
                            const std::string& where) const {
  return node.attribute(name) ? number(node, name, where) : fallback;
}

int XmlSource::integer(const pugi::xml_node& node, const char* name, const std::string& where) const {
  const pugi::xml_attribute a = node.attribute(name);
  if (!a) fail(node, where, std::string("missing attribute '") + name + "'");
  const std::string v = trim(a.value());
  std::string_view body(v);
  if (!body.empty() && body[0] == '+') body.remove_prefix(1);
  long long out = 0;
  const auto [ptr, ec] = std::from_chars(body.data(), body.data() + body.size(), out);
  if (body.empty() || ec != std::errc() || ptr != body.data() + body.size() || out < -1000000000LL ||
      out > 1000000000LL)
    fail(node, where, std::string("attribute '") + name + "' is not an integer: " + quoted_value(a.value()));
  return static_cast<int>(out);
}

std::string XmlSource::string(const pugi::xml_node& node, const char* name, const std::string& where) const {
  const pugi::xml_attribute a = node.attribute(name);
  if (!a) fail(node, where, std::string("missing attribute '") + name + "'");
  return trim(a.value());
}

std::string XmlSource::string_or(const pugi::xml_node& node, const char* name, const std::string& fallback) const {
  const pugi::xml_attribute a = node.attribute(name);
  return a ? trim(a.value()) : fallback;
}

bool XmlSource::boolean_or(const pugi::xml_node& node, const char* name, bool fallback,
                           const std::string& where) const {
  const pugi::xml_attribute a = node.attribute(name);
  if (!a) return fallback;
  const std::string v = trim(a.value());
  if (v == "true" || v == "1") return true;
  if (v == "false" || v == "0") return false;
  warn(node, where, std::string("attribute '") + name + "' is not a boolean: " + quoted_value(v) + "; using " +
                        (fallback ? "true" : "false"));
  return fallback;
}

}  // namespace icube::scene::odr

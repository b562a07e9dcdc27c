// Errors and warnings from readers of user files.
//
// Every reader reports bad input as InputError whose message is one line:
// "<file>: <where>: <what>", e.g.
//   "scenario.tfrecord: record 3 at byte 1048592: length 18446744 exceeds the file"
//   "Town01.xodr: road 12 geometry 3 (line 118): attribute 'length' is NaN"
// Problems the reader can work around (a zero-length polyline, a track with
// no valid state) go to a Diagnostics list as warnings instead.
#pragma once

#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace icube::scene {

class InputError : public std::runtime_error {
 public:
  InputError(const std::string& file, const std::string& where, const std::string& what)
      : std::runtime_error(file + ": " + (where.empty() ? "" : where + ": ") + what), file_(file) {}
  const std::string& file() const { return file_; }

 private:
  std::string file_;
};

// User text for a message: at most max_len characters, anything but printable
// ASCII as '?', "..." when cut, so the message stays one short line.
inline std::string printable(std::string_view s, size_t max_len = 64) {
  std::string out;
  for (char c : s.substr(0, max_len)) out += (c >= 0x20 && c < 0x7f) ? c : '?';
  if (s.size() > max_len) out += "...";
  return out;
}

struct Diagnostics {
  std::vector<std::string> warnings;
  void warn(const std::string& file, const std::string& where, const std::string& what) {
    warnings.push_back(file + ": " + (where.empty() ? "" : where + ": ") + what);
  }
};

}  // namespace icube::scene

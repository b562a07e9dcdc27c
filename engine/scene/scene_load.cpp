// Opening any supported scene file: the format is decided by the first bytes,
// the extension only breaks ties when the content says nothing (an empty or
// truncated file), so that the matching reader reports the real problem.
//
//   icube scene JSON   first non-blank byte is '{'
//   Waymo TFRecord     bytes 8-11 are the masked CRC32C of the 8 length bytes
//   OpenDRIVE          XML whose root element is <OpenDRIVE>
//   otherwise          the extension: .json, .tfrecord / .tfrecord-NNNNN-of-NNNNN, .xodr
#include "scene/scene_load.h"

#include "scene/tfrecord.h"

#include "scene/scene_json.h"
#include "scene/waymo_reader.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string_view>

namespace icube::scene {

namespace {

constexpr size_t kSniffBytes = 64 * 1024;  // room for an XML prolog with long comments
constexpr uint64_t kMaxPlausibleRecord = uint64_t(1) << 40;

const char* const kSupported =
    "supported: icube scene JSON (.json), Waymo Open Motion Dataset Scenario TFRecord (.tfrecord), "
    "OpenDRIVE 1.4-1.8 (.xodr)";

uint64_t load_le(const uint8_t* p, int bytes) {
  uint64_t v = 0;
  for (int i = bytes - 1; i >= 0; --i) v = (v << 8) | p[i];
  return v;
}

bool is_blank(char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r'; }

std::string_view skip_bom_and_blanks(std::string_view s) {
  if (s.substr(0, 3) == "\xEF\xBB\xBF") s.remove_prefix(3);
  while (!s.empty() && is_blank(s.front())) s.remove_prefix(1);
  return s;
}

bool looks_like_tfrecord(std::string_view head) {
  if (head.size() < 12) return false;
  const auto* p = reinterpret_cast<const uint8_t*>(head.data());
  const uint64_t length = load_le(p, 8);
  return length > 0 && length <= kMaxPlausibleRecord && uint32_t(load_le(p + 8, 4)) == mask_crc32c(crc32c(p, 8));
}

// The name of the XML root element, "" when `s` is not XML or the prolog runs past the sniffed bytes.
std::string xml_root_name(std::string_view s) {
  s = skip_bom_and_blanks(s);
  while (!s.empty() && s.front() == '<') {
    std::string_view end;
    if (s.substr(0, 2) == "<?") end = "?>";
    else if (s.substr(0, 4) == "<!--") end = "-->";
    else if (s.substr(0, 2) == "<!") end = ">";  // <!DOCTYPE ...> without an internal subset
    else {
      size_t n = 1;
      while (n < s.size() && !is_blank(s[n]) && s[n] != '>' && s[n] != '/') ++n;
      return std::string(s.substr(1, n - 1));
    }
    const size_t close = s.find(end);
    if (close == std::string_view::npos) return "";
    s = skip_bom_and_blanks(s.substr(close + end.size()));
  }
  return "";
}

std::string lower_extension(const std::string& path) {
  std::string name = std::filesystem::path(path).filename().string();
  std::transform(name.begin(), name.end(), name.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return name;
}

SceneFormat format_from_name(const std::string& path) {
  const std::string name = lower_extension(path);
  auto ends_with = [&](std::string_view suffix) {
    return name.size() >= suffix.size() && name.compare(name.size() - suffix.size(), suffix.size(), suffix) == 0;
  };
  if (ends_with(".json")) return SceneFormat::IcubeJson;
  if (ends_with(".xodr")) return SceneFormat::OpenDrive;
  // Waymo shards are named "training.tfrecord-00000-of-01000".
  if (ends_with(".tfrecord") || name.find(".tfrecord-") != std::string::npos) return SceneFormat::WaymoTfRecord;
  return SceneFormat::Unknown;
}

std::string read_head(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) throw InputError(path, "", "is a directory, not a scene file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, "", std::string("cannot open: ") + std::strerror(errno));
  std::string head(kSniffBytes, '\0');
  in.read(head.data(), std::streamsize(head.size()));
  if (in.bad()) throw InputError(path, "", "read error");
  head.resize(size_t(in.gcount()));
  return head;
}

// Why a file is not a scene file, for the "unknown format" message.
std::string describe_unknown(const std::string& head) {
  const std::string_view s = skip_bom_and_blanks(head);
  if (head.empty()) return "the file is empty";
  if (head.size() >= 2 && uint8_t(head[0]) == 0x1F && uint8_t(head[1]) == 0x8B)
    return "the file is gzip-compressed; decompress it first";
  if (!s.empty() && s.front() == '<') {
    const std::string root = xml_root_name(head);
    if (!root.empty()) return "XML with root element <" + root + ">, not <OpenDRIVE>";
    return "XML without a root element in the first " + std::to_string(kSniffBytes / 1024) + " KiB";
  }
  if (!s.empty() && s.front() == '[') return "JSON whose top level is an array, not an icube scene object";
  return "unrecognised content";
}

}  // namespace

SceneFormat detect_scene_format(const std::string& path) {
  const std::string head = read_head(path);
  const std::string_view s = skip_bom_and_blanks(head);
  if (!s.empty() && s.front() == '{') return SceneFormat::IcubeJson;
  if (looks_like_tfrecord(head)) return SceneFormat::WaymoTfRecord;
  if (!s.empty() && s.front() == '<' && xml_root_name(head) == "OpenDRIVE") return SceneFormat::OpenDrive;
  // Nothing recognisable (empty, truncated, a long XML prolog, a damaged
  // header): a file named like one of ours goes to that reader, which says
  // precisely what is wrong.
  return format_from_name(path);
}

const char* scene_format_name(SceneFormat f) {
  switch (f) {
    case SceneFormat::IcubeJson: return "icube-json";
    case SceneFormat::WaymoTfRecord: return "waymo-tfrecord";
    case SceneFormat::OpenDrive: return "opendrive";
    default: return "unknown";
  }
}

Scene load_scene(const std::string& path, const LoadOptions& options, Diagnostics* diag) {
  const SceneFormat format = detect_scene_format(path);
  if (format != SceneFormat::WaymoTfRecord && !options.waymo_selector.empty() && diag)
    diag->warn(path, "", "record selector '" + options.waymo_selector + "' ignored: not a TFRecord file");
  switch (format) {
    case SceneFormat::IcubeJson: return read_scene_json(path, diag);
    case SceneFormat::WaymoTfRecord: return read_waymo_scenario(path, options.waymo_selector, diag);
    case SceneFormat::OpenDrive: return read_opendrive(path, options.opendrive, diag);
    default: break;
  }
  throw InputError(path, "", "not a scene file (" + describe_unknown(read_head(path)) + "); " + kSupported);
}

}  // namespace icube::scene

// The appearance-frames folder; see frames_layout.h.
#include "render/appearance/frames_layout.h"

#include "scene/input_error.h"

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace icube::render {

std::string frame_file_name(size_t index) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%06zu.png", index);
  return buf;
}

std::string frames_meta_json(const FramesMeta& m) {
  nlohmann::ordered_json j;
  j["format"] = "icube-frames";
  j["version"] = 1;
  j["source"] = m.source;
  j["width"] = m.width;
  j["height"] = m.height;
  j["count"] = m.source_frame_indices.size();
  j["prompt"] = m.prompt;
  j["appearance"] = {{"time_of_day", time_of_day_name(m.parsed.time)},
                     {"weather", weather_name(m.parsed.weather)},
                     {"season", season_name(m.parsed.season)},
                     {"intensity", m.parsed.intensity},
                     {"unknown_words", m.parsed.unknown}};
  j["seed"] = m.seed;
  j["source_frame_indices"] = m.source_frame_indices;
  j["source_time_indices"] = m.source_time_indices;
  j["camera"] = {m.K.fx, m.K.fy, m.K.cx, m.K.cy, m.K.width, m.K.height};
  nlohmann::ordered_json poses = nlohmann::ordered_json::array();
  for (const glm::dmat4& c2w : m.poses) {
    nlohmann::ordered_json rows = nlohmann::ordered_json::array();
    for (int r = 0; r < 4; ++r) rows.push_back({c2w[0][r], c2w[1][r], c2w[2][r], c2w[3][r]});
    poses.push_back(rows);
  }
  j["poses"] = poses;
  j["pixels"] = m.pixels == PixelConvention::Centre ? "centre" : "integer";
  j["sky_mask"] = m.sky_mask;
  j["notes"] = m.notes;
  return j.dump(1) + "\n";
}

namespace {

// The largest |RᵀR − I| element, det R and the bottom row's deviation of a pose (0 for a rigid one).
std::string pose_error(const glm::dmat4& m) {
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r)
      if (!std::isfinite(m[c][r])) return "not finite";
  if (m[0][3] != 0.0 || m[1][3] != 0.0 || m[2][3] != 0.0 || m[3][3] != 1.0) return "bottom row is not (0, 0, 0, 1)";
  const glm::dmat3 r(m);
  const glm::dmat3 e = glm::transpose(r) * r;
  for (int c = 0; c < 3; ++c)
    for (int k = 0; k < 3; ++k)
      if (std::fabs(e[c][k] - (c == k ? 1.0 : 0.0)) > 1e-5) return "rotation is not orthonormal";
  if (glm::determinant(r) <= 0.0) return "rotation is a reflection";
  return {};
}

}  // namespace

FramesMeta read_frames_meta(const std::string& dir) {
  namespace fs = std::filesystem;
  const std::string file = (fs::path(dir) / "frames_meta.json").string();
  std::ifstream in(file, std::ios::binary);
  if (!in) throw scene::InputError(file, "", "cannot open (not an appearance-frames folder?)");
  std::stringstream ss;
  ss << in.rdbuf();
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(ss.str());
  } catch (const nlohmann::json::exception& e) {
    throw scene::InputError(file, "", std::string("not JSON: ") + e.what());
  }
  auto need = [&](const char* key) -> const nlohmann::json& {
    if (!j.is_object() || !j.contains(key)) throw scene::InputError(file, std::string("/") + key, "missing");
    return j[key];
  };
  FramesMeta m;
  try {
    if (need("format") != "icube-frames") throw scene::InputError(file, "/format", "is not \"icube-frames\"");
    if (need("version") != 1) throw scene::InputError(file, "/version", "unsupported (this build reads 1)");
    m.source = need("source").get<std::string>();
    m.width = need("width").get<uint32_t>();
    m.height = need("height").get<uint32_t>();
    const size_t count = need("count").get<size_t>();
    m.prompt = need("prompt").get<std::string>();
    m.parsed = parse_prompt(m.prompt);
    m.seed = j.value("seed", uint64_t{0});
    m.source_frame_indices = j.value("source_frame_indices", std::vector<int>{});
    m.source_time_indices = j.value("source_time_indices", std::vector<int>{});
    const std::vector<double> cam = need("camera").get<std::vector<double>>();
    if (cam.size() != 6) throw scene::InputError(file, "/camera", "needs [fx, fy, cx, cy, width, height]");
    for (size_t i = 0; i < 4; ++i)
      if (!std::isfinite(cam[i]) || (i < 2 && cam[i] <= 0.0))
        throw scene::InputError(file, "/camera/" + std::to_string(i), "must be finite (and positive for fx, fy)");
    m.K.fx = cam[0], m.K.fy = cam[1], m.K.cx = cam[2], m.K.cy = cam[3];
    m.K.width = static_cast<uint32_t>(cam[4]);
    m.K.height = static_cast<uint32_t>(cam[5]);
    if (m.K.width != m.width || m.K.height != m.height || m.width == 0 || m.height == 0)
      throw scene::InputError(file, "/camera", "image size disagrees with /width, /height or is zero");
    const nlohmann::json& poses = need("poses");
    if (!poses.is_array() || poses.size() != count)
      throw scene::InputError(file, "/poses", "needs one 4x4 pose per frame (" + std::to_string(count) + ")");
    for (size_t f = 0; f < count; ++f) {
      const auto rows = poses[f].get<std::vector<std::vector<double>>>();
      if (rows.size() != 4) throw scene::InputError(file, "/poses/" + std::to_string(f), "needs 4 rows");
      glm::dmat4 c2w(1.0);
      for (int r = 0; r < 4; ++r) {
        if (rows[size_t(r)].size() != 4) throw scene::InputError(file, "/poses/" + std::to_string(f), "needs 4 columns");
        for (int c = 0; c < 4; ++c) c2w[c][r] = rows[size_t(r)][size_t(c)];
      }
      const std::string err = pose_error(c2w);
      if (!err.empty()) throw scene::InputError(file, "/poses/" + std::to_string(f), err);
      m.poses.push_back(c2w);
    }
    const std::string px = j.value("pixels", std::string("integer"));
    if (px != "integer" && px != "centre") throw scene::InputError(file, "/pixels", "must be \"integer\" or \"centre\"");
    m.pixels = px == "centre" ? PixelConvention::Centre : PixelConvention::Integer;
    m.sky_mask = j.value("sky_mask", std::string("buffers"));
    if (m.sky_mask != "buffers" && m.sky_mask != "segmentation")
      throw scene::InputError(file, "/sky_mask", "must be \"buffers\" or \"segmentation\"");
    if (j.contains("notes")) m.notes = j["notes"].get<std::vector<std::string>>();
    m.source_frame_indices.resize(count, -1);
    m.source_time_indices.resize(count, -1);
  } catch (const nlohmann::json::exception& e) {
    throw scene::InputError(file, "", std::string("wrong type: ") + e.what());
  }
  for (size_t f = 0; f < m.poses.size(); ++f)
    for (const char* sub : {"rgb", "sky_mask", "instance"}) {
      const fs::path png = fs::path(dir) / sub / frame_file_name(f);
      if (!fs::is_regular_file(png)) throw scene::InputError(file, "/count", "frame " + std::to_string(f) + ": " + png.string() + " is missing");
    }
  return m;
}

}  // namespace icube::render

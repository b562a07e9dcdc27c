// The appearance-frames folder; see frames_layout.h.
#include "render/appearance/frames_layout.h"

#include <nlohmann/json.hpp>

#include <cstdio>

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
  j["notes"] = m.notes;
  return j.dump(1) + "\n";
}

}  // namespace icube::render

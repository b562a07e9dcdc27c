// LiDAR file writers and readers; see lidar_io.h.
#include "render/lidar/lidar_io.h"

#include "scene/atomic_file.h"
#include "scene/input_error.h"
#include "scene/png_write.h"
#include "world/npy.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <sstream>

namespace icube::render {

namespace {

void put_u8(std::string& out, uint8_t v) { out.push_back(static_cast<char>(v)); }
void put_u16(std::string& out, uint16_t v) {
  out.push_back(static_cast<char>(v & 0xff));
  out.push_back(static_cast<char>(v >> 8));
}
void put_u32(std::string& out, uint32_t v) {
  for (int b = 0; b < 4; ++b) out.push_back(static_cast<char>((v >> (8 * b)) & 0xff));
}
void put_f32(std::string& out, float v) { put_u32(out, std::bit_cast<uint32_t>(v)); }

uint32_t get_u32(const char* p) {
  uint32_t v = 0;
  for (int b = 0; b < 4; ++b) v |= uint32_t{static_cast<uint8_t>(p[b])} << (8 * b);
  return v;
}
uint16_t get_u16(const char* p) {
  return static_cast<uint16_t>(uint32_t{static_cast<uint8_t>(p[0])} | (uint32_t{static_cast<uint8_t>(p[1])} << 8));
}
float get_f32(const char* p) { return std::bit_cast<float>(get_u32(p)); }

constexpr const char* kPlyProperties[] = {
    "property float x",        "property float y",      "property float z",     "property float intensity",
    "property uchar class",    "property ushort instance", "property ushort ring", "property float range",
};

std::string frame_id(int index) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%06d", index);
  return buf;
}

std::vector<double> row_major(const glm::dmat4& m) {
  std::vector<double> v;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) v.push_back(m[c][r]);
  return v;
}

}  // namespace

std::string encode_lidar_ply(const LidarScan& s, bool world_frame) {
  std::string out = "ply\nformat binary_little_endian 1.0\n";
  out += world_frame ? "comment icube lidar: x y z in the world frame (metres, z up)\n"
                     : "comment icube lidar: x y z in the sensor frame (FLU: x forward, y left, z up, metres)\n";
  out += "comment frame " + frame_id(s.frame_index) + ", " + std::to_string(s.beams) + " beams x " +
         std::to_string(s.columns) + " columns\n";
  out += "element vertex " + std::to_string(s.returns.size()) + "\n";
  for (const char* p : kPlyProperties) out += std::string(p) + "\n";
  out += "end_header\n";
  out.reserve(out.size() + s.returns.size() * kLidarPlyVertexBytes);
  for (const LidarReturn& r : s.returns) {
    const glm::vec3 p = world_frame ? glm::vec3(r.world) : r.sensor;
    put_f32(out, p.x);
    put_f32(out, p.y);
    put_f32(out, p.z);
    put_f32(out, r.intensity);
    put_u8(out, r.class_id);
    put_u16(out, r.instance);
    put_u16(out, r.ring);
    put_f32(out, r.range);
  }
  return out;
}

std::vector<LidarPlyPoint> parse_lidar_ply(std::string_view bytes, const std::string& name) {
  const size_t end = bytes.find("end_header\n");
  if (bytes.substr(0, 4) != "ply\n" || end == std::string_view::npos)
    throw scene::InputError(name, "header", "not a PLY file");
  std::istringstream hs{std::string(bytes.substr(0, end))};
  std::string line;
  std::vector<std::string> props;
  long long count = -1;
  bool format = false;
  while (std::getline(hs, line)) {
    if (line == "ply" || line.rfind("comment", 0) == 0) continue;
    if (line == "format binary_little_endian 1.0") format = true;
    else if (line.rfind("element vertex ", 0) == 0) count = std::atoll(line.c_str() + 15);
    else if (line.rfind("property ", 0) == 0) props.push_back(line);
    else throw scene::InputError(name, "header", "unexpected line '" + line + "'");
  }
  if (!format) throw scene::InputError(name, "header", "expected format binary_little_endian 1.0");
  if (count < 0) throw scene::InputError(name, "header", "no vertex element");
  if (props != std::vector<std::string>(std::begin(kPlyProperties), std::end(kPlyProperties)))
    throw scene::InputError(name, "header", "properties differ from the icube LiDAR layout");
  const size_t body = end + 11;
  if (bytes.size() - body != static_cast<size_t>(count) * kLidarPlyVertexBytes)
    throw scene::InputError(name, "body", "expected " + std::to_string(count) + " vertices of 25 bytes, got " +
                                              std::to_string(bytes.size() - body) + " bytes");
  std::vector<LidarPlyPoint> pts(static_cast<size_t>(count));
  for (size_t i = 0; i < pts.size(); ++i) {
    const char* p = bytes.data() + body + i * kLidarPlyVertexBytes;
    LidarPlyPoint& q = pts[i];
    q.x = get_f32(p);
    q.y = get_f32(p + 4);
    q.z = get_f32(p + 8);
    q.intensity = get_f32(p + 12);
    q.class_id = static_cast<uint8_t>(p[16]);
    q.instance = get_u16(p + 17);
    q.ring = get_u16(p + 19);
    q.range = get_f32(p + 21);
  }
  return pts;
}

std::string encode_kitti_bin(const LidarScan& s) {
  std::string out;
  out.reserve(s.returns.size() * 16);
  for (const LidarReturn& r : s.returns) {
    put_f32(out, r.sensor.x);
    put_f32(out, r.sensor.y);
    put_f32(out, r.sensor.z);
    put_f32(out, r.intensity);
  }
  return out;
}

std::vector<std::array<float, 4>> parse_kitti_bin(std::string_view bytes, const std::string& name) {
  if (bytes.size() % 16 != 0)
    throw scene::InputError(name, "size", "not a multiple of 16 bytes (float32 x, y, z, intensity)");
  std::vector<std::array<float, 4>> pts(bytes.size() / 16);
  for (size_t i = 0; i < pts.size(); ++i)
    for (int k = 0; k < 4; ++k) pts[i][static_cast<size_t>(k)] = get_f32(bytes.data() + 16 * i + 4 * k);
  return pts;
}

std::vector<uint16_t> range_image_centimetres(const LidarScan& s) {
  std::vector<uint16_t> out(s.range.size(), 0);
  for (size_t i = 0; i < s.range.size(); ++i) {
    const double cm = std::trunc(static_cast<double>(s.range[i]) * 100.0);
    out[i] = cm >= 65535.0 ? uint16_t{65535} : cm > 0.0 ? static_cast<uint16_t>(cm) : uint16_t{0};
  }
  return out;
}

std::array<uint8_t, 3> lidar_range_colour(double range, double max_range) {
  if (!(range > 0.0) || !(max_range > 0.0)) return {0, 0, 0};
  // Control points of the ramp (t = sqrt(range / max_range)).
  static constexpr double kStops[7][3] = {{230, 30, 30},  {250, 150, 20}, {235, 225, 50}, {70, 200, 90},
                                          {40, 170, 220}, {50, 70, 210},  {90, 30, 130}};
  const double t = std::sqrt(std::clamp(range / max_range, 0.0, 1.0)) * 6.0;
  const int k = std::min(5, static_cast<int>(t));
  const double f = t - k;
  std::array<uint8_t, 3> c{};
  for (int ch = 0; ch < 3; ++ch)
    c[static_cast<size_t>(ch)] =
        static_cast<uint8_t>(std::lround(kStops[k][ch] + (kStops[k + 1][ch] - kStops[k][ch]) * f));
  return c;
}

uint32_t range_view_row_repeat(uint32_t beams) { return std::max(1u, std::min(8u, beams ? 256u / beams : 1u)); }

std::vector<uint8_t> range_image_rgb(const LidarScan& s, double max_range, uint32_t row_repeat) {
  row_repeat = std::max(1u, row_repeat);
  std::vector<uint8_t> out(static_cast<size_t>(s.beams) * row_repeat * s.columns * 3);
  for (uint32_t r = 0; r < s.beams; ++r)
    for (uint32_t c = 0; c < s.columns; ++c) {
      const std::array<uint8_t, 3> col = lidar_range_colour(static_cast<double>(s.range[static_cast<size_t>(r) * s.columns + c]), max_range);
      for (uint32_t k = 0; k < row_repeat; ++k)
        std::memcpy(&out[((static_cast<size_t>(r) * row_repeat + k) * s.columns + c) * 3], col.data(), 3);
    }
  return out;
}

std::string lidar_poses_npy(const std::vector<glm::dmat4>& poses) {
  std::vector<double> v;
  for (const glm::dmat4& m : poses) {
    const std::vector<double> rm = row_major(m);
    v.insert(v.end(), rm.begin(), rm.end());
  }
  return world::npy_to_bytes(world::NpyArray::make<double>({poses.size(), 4, 4}, v));
}

void write_lidar_frame(const std::string& dir, const LidarScan& s, const LidarModel& m, const LidarWriteOptions& o) {
  namespace fs = std::filesystem;
  const std::string id = frame_id(s.frame_index);
  for (const char* sub : {"ply", "bin", "range", "range_color"}) fs::create_directories(fs::path(dir) / sub);
  scene::write_file_atomic(dir + "/ply/" + id + ".ply", encode_lidar_ply(s, o.world_frame_ply));
  scene::write_file_atomic(dir + "/bin/" + id + ".bin", encode_kitti_bin(s));
  const std::vector<uint16_t> cm = range_image_centimetres(s);
  scene::write_png_gray16(dir + "/range/" + id + ".png", cm.data(), static_cast<int>(s.columns),
                          static_cast<int>(s.beams));
  const uint32_t rep = range_view_row_repeat(s.beams);
  const std::vector<uint8_t> rgb = range_image_rgb(s, m.max_range, rep);
  scene::write_png(dir + "/range_color/" + id + ".png", rgb.data(), static_cast<int>(s.columns),
                   static_cast<int>(s.beams * rep), 3);
}

std::string lidar_meta_json(const LidarModel& m, const std::vector<int>& frame_indices, const LidarWriteOptions& o,
                            const std::string& source) {
  nlohmann::json j;
  j["format"] = "icube-lidar";
  j["version"] = 1;
  j["source"] = source;
  j["beams"] = m.beams();
  j["columns"] = m.columns;
  j["elevations_deg"] = m.elevations_deg;
  j["min_range"] = m.min_range;
  j["max_range"] = m.max_range;
  j["start_azimuth_deg"] = m.start_azimuth_deg;
  j["sensor_to_ego"] = nlohmann::json::array();
  for (int r = 0; r < 4; ++r)
    j["sensor_to_ego"].push_back({m.sensor_to_ego[0][r], m.sensor_to_ego[1][r], m.sensor_to_ego[2][r], m.sensor_to_ego[3][r]});
  j["frames"] = frame_indices;
  j["conventions"] = {
      {"sensor_frame", "FLU: x forward, y left, z up, metres"},
      {"azimuth", "column c: start_azimuth - 360 (c + 0.5) / columns degrees, counter-clockwise from +x"},
      {"ring", "0 = highest beam = top row of the range image"},
      {"range", o.range_convention},
      {"intensity", o.intensity_convention},
      {"ply_frame", o.world_frame_ply ? "world" : "sensor"},
      {"poses", "poses.npy: float64 [N,4,4] sensor-to-world, row-major"},
      {"range_png", "uint16 centimetres, truncated, 0 = no return"},
      {"sweep", "one sensor pose per sweep, motion during the rotation ignored"},
  };
  return j.dump(2) + "\n";
}

}  // namespace icube::render

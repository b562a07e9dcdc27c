// LiDAR geometry, presets and option parsing; see lidar_model.h.
#include "render/lidar/lidar_model.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <sstream>
#include <stdexcept>

namespace icube::render {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;

double parse_number(const std::string& s, const std::string& what) {
  char* end = nullptr;
  const double v = std::strtod(s.c_str(), &end);
  if (s.empty() || *end != '\0' || !std::isfinite(v)) throw std::invalid_argument(what + ": bad number '" + s + "'");
  return v;
}

}  // namespace

std::vector<double> uniform_elevations(uint32_t beams, double min_deg, double max_deg) {
  if (beams == 0) throw std::invalid_argument("lidar: at least one beam");
  if (!(std::isfinite(min_deg) && std::isfinite(max_deg) && min_deg <= max_deg))
    throw std::invalid_argument("lidar: elevation range needs MIN <= MAX");
  if (beams > 1 && !(min_deg < max_deg)) throw std::invalid_argument("lidar: several beams need MIN < MAX");
  std::vector<double> e(beams);
  for (uint32_t r = 0; r < beams; ++r)
    e[r] = beams == 1 ? max_deg : max_deg - (max_deg - min_deg) * static_cast<double>(r) / (beams - 1.0);
  return e;
}

glm::dmat4 lidar_mount(double height) {
  glm::dmat4 m(1.0);
  m[3] = {0.0, 0.0, height, 1.0};
  return m;
}

LidarModel waymo_top_lidar() {
  LidarModel m;
  m.elevations_deg = uniform_elevations(kWaymoTopBeams, kWaymoTopElevationMinDeg, kWaymoTopElevationMaxDeg);
  m.columns = kWaymoTopColumns;
  m.min_range = kWaymoTopMinRange;
  m.max_range = kWaymoTopMaxRange;
  m.start_azimuth_deg = 180.0;
  m.sensor_to_ego = lidar_mount(kWaymoTopMountHeight);
  return m;
}

LidarModel lidar_preset(const std::string& name) {
  if (name == "waymo-top") return waymo_top_lidar();
  throw std::invalid_argument("--preset: unknown LiDAR preset '" + name + "' (known: waymo-top)");
}

void validate_lidar(const LidarModel& m) {
  if (m.elevations_deg.empty()) throw std::invalid_argument("lidar: at least one beam");
  if (m.elevations_deg.size() > 65535) throw std::invalid_argument("lidar: at most 65535 beams (ring is uint16)");
  for (size_t r = 0; r < m.elevations_deg.size(); ++r) {
    const double e = m.elevations_deg[r];
    if (!(std::isfinite(e) && e > -90.0 && e < 90.0))
      throw std::invalid_argument("lidar: elevation " + std::to_string(e) + " outside (-90, 90) degrees");
    if (r > 0 && !(e < m.elevations_deg[r - 1]))
      throw std::invalid_argument("lidar: elevations must be distinct and in ring order (highest first)");
  }
  if (m.columns < 1 || m.columns > 65535) throw std::invalid_argument("lidar: columns must be in 1..65535");
  if (!(std::isfinite(m.min_range) && std::isfinite(m.max_range) && m.min_range >= 0.0 && m.min_range < m.max_range &&
        m.max_range <= 655.0))
    throw std::invalid_argument("lidar: range needs 0 <= MIN < MAX <= 655 m");
  if (!std::isfinite(m.start_azimuth_deg)) throw std::invalid_argument("lidar: non-finite start azimuth");
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r)
      if (!std::isfinite(m.sensor_to_ego[c][r])) throw std::invalid_argument("lidar: non-finite sensor mount");
  const glm::dmat3 R(m.sensor_to_ego);
  const glm::dmat3 E = glm::transpose(R) * R - glm::dmat3(1.0);
  double err = 0.0;
  for (int c = 0; c < 3; ++c)
    for (int r = 0; r < 3; ++r) err = std::max(err, std::fabs(E[c][r]));
  if (err > 1e-6 || glm::determinant(R) < 0.0 || m.sensor_to_ego[0][3] != 0.0 || m.sensor_to_ego[1][3] != 0.0 ||
      m.sensor_to_ego[2][3] != 0.0 || m.sensor_to_ego[3][3] != 1.0)
    throw std::invalid_argument("lidar: the sensor mount is not a rigid transform");
}

double lidar_column_azimuth(const LidarModel& m, uint32_t column) {
  return m.start_azimuth_deg * kDeg - 2.0 * kPi * (static_cast<double>(column) + 0.5) / m.columns;
}

glm::dvec3 lidar_direction(double e, double a) {
  return {std::cos(e) * std::cos(a), std::cos(e) * std::sin(a), std::sin(e)};
}

std::vector<glm::dvec3> lidar_directions(const LidarModel& m) {
  std::vector<glm::dvec3> d;
  d.reserve(m.rays());
  for (uint32_t r = 0; r < m.beams(); ++r)
    for (uint32_t c = 0; c < m.columns; ++c)
      d.push_back(lidar_direction(m.elevations_deg[r] * kDeg, lidar_column_azimuth(m, c)));
  return d;
}

void parse_min_max(const std::string& text, const char* option, double* lo, double* hi) {
  const size_t colon = text.find(':');
  if (colon == std::string::npos || text.find(':', colon + 1) != std::string::npos)
    throw std::invalid_argument(std::string(option) + ": expected MIN:MAX, got '" + text + "'");
  const double a = parse_number(text.substr(0, colon), option), b = parse_number(text.substr(colon + 1), option);
  if (!(a < b)) throw std::invalid_argument(std::string(option) + ": MIN must be below MAX in '" + text + "'");
  *lo = a;
  *hi = b;
}

std::vector<double> parse_elevation_list(const std::string& text) {
  std::vector<double> v;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) v.push_back(parse_number(item, "--elevations"));
  if (v.empty() || (!text.empty() && text.back() == ','))
    throw std::invalid_argument("--elevations: expected a comma-separated list of degrees");
  std::sort(v.begin(), v.end(), [](double a, double b) { return a > b; });
  return v;
}

}  // namespace icube::render

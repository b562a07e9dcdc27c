// A spinning LiDAR's geometry for the voxel ray caster: beams (elevation
// angles), azimuth columns per rotation, min/max range and the sensor's mount
// on the ego, plus the "waymo-top" preset.
//
// Conventions:
//  - Sensor frame = FLU (x forward, y left, z up, metres), the ego's frame
//    convention (scene.h); `sensor_to_ego` is a rigid 4x4 in FLU.
//  - Elevation: angle above the sensor's xy plane, degrees, + = up.
//    `elevations_deg` is in ring order: ring 0 = the highest beam, so rings
//    are the range image's rows top to bottom (Waymo's row order).
//  - Azimuth: atan2(y, x) in the sensor frame, counter-clockwise from +x
//    (forward) seen from above. Column c (0 .. columns-1) looks at
//        azimuth(c) = start_azimuth - 360° · (c + 0.5) / columns,
//    i.e. the head spins clockwise seen from above and column order is
//    decreasing azimuth. With start_azimuth = 180° the first column looks
//    backwards, the middle of the image forwards, and image left = the
//    ego's left (Waymo's range-image layout).
//  - Direction of (ring, column): (cos e cos a, cos e sin a, sin e).
//  - Ray index = ring · columns + column (row-major range image).
//  - One sweep is cast from one sensor pose (the frame's ego pose): motion
//    during the ~0.1 s rotation (rolling shutter) is ignored.
//
// waymo-top preset (numbers and their status):
//  - 64 beams, vertical FOV +2.4° .. -17.6°, 75 m maximum range: the Waymo
//    Open Dataset paper (Sun et al., CVPR 2020, table 1) for the top LiDAR.
//  - 2650 columns: the width of the dataset's top-LiDAR range images.
//  - Beam spacing: ASSUMED uniform (20° / 63 = 0.3175°). The real sensor's
//    inclinations are non-uniform and per vehicle (each segment's calibration
//    carries them); pass an explicit list to model one.
//  - min range 0.5 m: ASSUMED (drops returns from the sensor housing region).
//  - Mount: ASSUMED (0, 0, 2.2) m in the ego frame, no rotation: 2.2 m above
//    the ego origin, which our scenes put on the ground. (Real Waymo
//    calibrations put the top LiDAR roughly 2.2 m up, somewhat forward of
//    the vehicle origin; not verified here.)
//  - start azimuth 180°, clockwise columns: ASSUMED to match the dataset's
//    range-image layout (centre column = forward).
// Tests: tests/render/test_lidar.cpp.
#pragma once

#include <glm/glm.hpp>

#include <cstdint>
#include <string>
#include <vector>

namespace icube::render {

struct LidarModel {
  std::vector<double> elevations_deg;  // ring order: ring 0 = highest
  uint32_t columns = 0;                // azimuth steps per rotation
  double min_range = 0.0;              // metres: returns nearer are dropped
  double max_range = 0.0;              // metres: returns farther are dropped
  double start_azimuth_deg = 180.0;    // azimuth of column 0's leading edge
  glm::dmat4 sensor_to_ego{1.0};       // FLU, rigid
  uint32_t beams() const { return static_cast<uint32_t>(elevations_deg.size()); }
  uint64_t rays() const { return uint64_t{beams()} * columns; }
};

inline constexpr double kWaymoTopElevationMaxDeg = 2.4;
inline constexpr double kWaymoTopElevationMinDeg = -17.6;
inline constexpr uint32_t kWaymoTopBeams = 64;
inline constexpr uint32_t kWaymoTopColumns = 2650;
inline constexpr double kWaymoTopMaxRange = 75.0;
inline constexpr double kWaymoTopMinRange = 0.5;
inline constexpr double kWaymoTopMountHeight = 2.2;

// `beams` elevations from max_deg (ring 0) down to min_deg, evenly spaced
// (one beam: max_deg). Throws std::invalid_argument for beams == 0 or min > max.
std::vector<double> uniform_elevations(uint32_t beams, double min_deg, double max_deg);

LidarModel waymo_top_lidar();
// "waymo-top"; throws std::invalid_argument naming the known presets otherwise.
LidarModel lidar_preset(const std::string& name);
// Sensor mounted `height` metres above the ego origin, axes parallel to the ego's.
glm::dmat4 lidar_mount(double height);

// Throws std::invalid_argument: no beams, an elevation outside (-90°, 90°) or
// not strictly decreasing, columns outside 1..65535, beams > 65535, a bad
// range (need 0 <= min < max <= 655 m, so centimetres fit uint16), a
// non-finite start azimuth or a non-rigid mount.
void validate_lidar(const LidarModel& m);

double lidar_column_azimuth(const LidarModel& m, uint32_t column);  // radians
glm::dvec3 lidar_direction(double elevation_rad, double azimuth_rad);  // sensor frame, unit
// Every ray's unit direction in the sensor frame, ray index = ring · columns + column.
std::vector<glm::dvec3> lidar_directions(const LidarModel& m);

// CLI helpers (throw std::invalid_argument with the option's name):
// "MIN:MAX" of two finite numbers with MIN < MAX.
void parse_min_max(const std::string& text, const char* option, double* lo, double* hi);
// "e0,e1,..." degrees in any order; returned sorted highest first.
std::vector<double> parse_elevation_list(const std::string& text);

}  // namespace icube::render

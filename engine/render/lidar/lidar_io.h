// LiDAR outputs, one set of files per sweep, and their readers (for tests and
// users who check a file):
//
//   ply/NNNNNN.ply          binary_little_endian 1.0, one vertex per return:
//                           float x, y, z; float intensity; uchar class;
//                           ushort instance; ushort ring; float range (25 bytes,
//                           packed). x y z in the sensor frame (FLU) unless
//                           the world frame is asked for (absolute world
//                           metres as float32); a header comment names the
//                           frame.
//   bin/NNNNNN.bin          KITTI velodyne layout: float32 x, y, z, intensity per
//                           return, sensor frame (KITTI's is FLU too),
//                           intensity in [0, 1], no header.
//   range/NNNNNN.png        uint16 grey, beams x columns (row = ring, top beam
//                           first; column as lidar_model.h), range in
//                           centimetres truncated like the guidance depth
//                           (0 = no return).
//   range_color/NNNNNN.png  RGB8 for viewing: each row repeated `row_repeat`
//                           times, colour = a red-yellow-green-blue-purple ramp
//                           of sqrt(range / max_range) (near = red), black = no
//                           return.
//   poses.npy               float64 [N, 4, 4] sensor-to-world (FLU sensor axes,
//                           scene world frame), row-major, trajectory order.
//   lidar.json              the model, the frames and the conventions.
// NNNNNN = the frame index (the scene state), 6 digits. Returns in ray order
// (ring-major). Every file goes through scene::write_file_atomic.
// Tests: tests/render/test_lidar.cpp.
#pragma once

#include "render/lidar/lidar_scan.h"

#include <array>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace icube::render {

inline constexpr size_t kLidarPlyVertexBytes = 25;

struct LidarPlyPoint {
  float x = 0, y = 0, z = 0, intensity = 0;
  uint8_t class_id = 0;
  uint16_t instance = 0, ring = 0;
  float range = 0;
};

std::string encode_lidar_ply(const LidarScan& s, bool world_frame = false);
// Reads exactly the layout encode_lidar_ply writes; throws scene::InputError(name, ...) otherwise.
std::vector<LidarPlyPoint> parse_lidar_ply(std::string_view bytes, const std::string& name);

std::string encode_kitti_bin(const LidarScan& s);
// float32 quadruples; throws scene::InputError when the size is not a multiple of 16.
std::vector<std::array<float, 4>> parse_kitti_bin(std::string_view bytes, const std::string& name);

std::vector<uint16_t> range_image_centimetres(const LidarScan& s);
std::array<uint8_t, 3> lidar_range_colour(double range, double max_range);  // range 0 = black
std::vector<uint8_t> range_image_rgb(const LidarScan& s, double max_range, uint32_t row_repeat);
// Rows repeated for range_color/: max(1, min(8, 256 / beams)).
uint32_t range_view_row_repeat(uint32_t beams);

// Row-major float64 [N, 4, 4].
std::string lidar_poses_npy(const std::vector<glm::dmat4>& sensor_to_world);

struct LidarWriteOptions {
  bool world_frame_ply = false;
  // lidar.json's conventions of what range and intensity mean (the voxel caster's by default; the
  // Gaussian caster's say how it measures them).
  std::string range_convention = "entry distance of the first >= 0.1 m run of occupied voxels";
  std::string intensity_convention = "reflectivity(class) * |cos(incidence)| on the voxel face entering the depth run, [0, 1]";
};
// Writes the four per-frame files of `s` under `dir` (creates the sub-folders).
void write_lidar_frame(const std::string& dir, const LidarScan& s, const LidarModel& m, const LidarWriteOptions& o);
// lidar.json text.
std::string lidar_meta_json(const LidarModel& m, const std::vector<int>& frame_indices,
                            const LidarWriteOptions& o, const std::string& source);

}  // namespace icube::render

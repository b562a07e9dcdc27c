// The synthetic street of icube-bench-gsm; see gsm_street_scene.h.
#include "gsm_street_scene.h"

#include "nn/gsm/gsm_rays.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <vector>

namespace icube::bench {

namespace {

using Rgb = std::array<float, 3>;

// What a voxel is, for its colour.
enum class Surface : uint8_t { Road, Sidewalk, Facade, Car };

struct VoxelInfo {
  Surface surface = Surface::Road;
  uint8_t id = 0;  // building or car index
};

uint64_t key_of(int32_t i, int32_t j, int32_t k) {
  return (static_cast<uint64_t>(static_cast<uint32_t>(i) & 0x1FFFFF) << 42) |
         (static_cast<uint64_t>(static_cast<uint32_t>(j) & 0x1FFFFF) << 21) | (static_cast<uint32_t>(k) & 0x1FFFFF);
}

// A value in [-1, 1) from integers (a small integer hash), for per-voxel and per-pixel noise.
float hash_noise(uint64_t a, uint64_t b) {
  uint64_t h = a * 0x9E3779B97F4A7C15ull ^ (b + 0x632BE59BD9B4E019ull + (a << 6) + (a >> 2));
  h ^= h >> 31;
  h *= 0xBF58476D1CE4E5B9ull;
  h ^= h >> 29;
  return static_cast<float>(h >> 40) / static_cast<float>(1ull << 23) - 1.0f;
}

constexpr Rgb kFacadeColours[4] = {{0.62f, 0.52f, 0.44f}, {0.72f, 0.70f, 0.64f}, {0.50f, 0.36f, 0.30f}, {0.56f, 0.60f, 0.62f}};
constexpr Rgb kCarColours[6] = {{0.70f, 0.10f, 0.10f}, {0.12f, 0.14f, 0.18f}, {0.85f, 0.85f, 0.86f},
                                {0.15f, 0.25f, 0.55f}, {0.55f, 0.56f, 0.58f}, {0.30f, 0.40f, 0.25f}};
constexpr Rgb kAsphalt = {0.33f, 0.33f, 0.35f};
constexpr Rgb kMarking = {0.90f, 0.90f, 0.88f};
constexpr Rgb kPavement = {0.62f, 0.60f, 0.56f};
constexpr Rgb kWindow = {0.16f, 0.20f, 0.26f};

// Street layout in voxels (0.2 m): the road spans x in [0, 80) m, y in [-6, 6) m.
constexpr int32_t kStreetLength = 400;  // i in [0, 400)
constexpr int32_t kRoadHalf = 30;       // j in [-30, 30)
constexpr int32_t kSidewalkHalf = 40;   // sidewalks j in [-40, -30) and [30, 40), raised by one voxel
constexpr double kFacadeY = 8.0;        // facades at |y| in [8.0, 8.2)

// Facade heights in voxels per 20 m block (8 to 16 m); alleys of 3 m at the end of each block.
int32_t facade_height(int32_t block, int side) { return 40 + ((block * 7 + side * 3) % 5) * 10; }
bool in_alley(int32_t i) { return i % 100 >= 85; }

bool window_at(double along, double z) {
  const double a = std::fmod(along, 2.0), h = std::fmod(z, 3.0);
  return z > 1.0 && a > 0.6 && a < 1.4 && h > 0.8 && h < 2.2;
}

Rgb facade_colour(int building, double along, double z) {
  return window_at(along, z) ? kWindow : kFacadeColours[static_cast<size_t>(building) % 4];
}

struct Street {
  std::vector<nn::Ijk> voxels;
  std::unordered_map<uint64_t, VoxelInfo> info;

  void add(int32_t i, int32_t j, int32_t k, VoxelInfo v) {
    if (info.emplace(key_of(i, j, k), v).second) voxels.push_back({i, j, k});
  }
};

Street build_street() {
  Street s;
  for (int32_t i = 0; i < kStreetLength; ++i) {
    for (int32_t j = -kRoadHalf; j < kRoadHalf; ++j) s.add(i, j, -1, {Surface::Road, 0});
    for (int32_t j = kRoadHalf; j < kSidewalkHalf; ++j)
      for (int32_t k = -1; k <= 0; ++k) {
        s.add(i, j, k, {Surface::Sidewalk, 0});
        s.add(i, -1 - j, k, {Surface::Sidewalk, 0});
      }
    if (in_alley(i)) continue;
    const int32_t block = i / 100;
    for (int side = 0; side < 2; ++side) {
      const int32_t j = side == 0 ? kSidewalkHalf : -kSidewalkHalf - 1;
      for (int32_t k = 0; k < facade_height(block, side); ++k)
        s.add(i, j, k, {Surface::Facade, static_cast<uint8_t>(block * 2 + side)});
    }
  }
  // Parked cars, 4.4 x 1.8 x 1.6 m, as shells.
  const int32_t car_x[3] = {75, 160, 275};
  uint8_t id = 0;
  for (int side = 0; side < 2; ++side)
    for (int32_t x0 : car_x) {
      const int32_t i0 = x0 + side * 40, j0 = side == 0 ? -29 : 20, k0 = 0;
      for (int32_t i = i0; i < i0 + 22; ++i)
        for (int32_t j = j0; j < j0 + 9; ++j)
          for (int32_t k = k0; k < k0 + 8; ++k) {
            const bool shell = i == i0 || i == i0 + 21 || j == j0 || j == j0 + 8 || k == k0 + 7;
            if (shell && k > k0) s.add(i, j, k, {Surface::Car, id});
          }
      ++id;
    }
  std::sort(s.voxels.begin(), s.voxels.end());
  return s;
}

Rgb voxel_colour(const Street& s, const nn::Ijk& v) {
  const VoxelInfo info = s.info.at(key_of(v[0], v[1], v[2]));
  const double x = 0.2 * v[0] + 0.1, y = 0.2 * v[1] + 0.1, z = 0.2 * v[2] + 0.1;
  Rgb c{};
  switch (info.surface) {
    case Surface::Road: {
      const bool centre_dash = (v[1] == -1 || v[1] == 0) && (v[0] / 15) % 2 == 0;
      const bool edge = v[1] == -kRoadHalf || v[1] == kRoadHalf - 1;
      c = centre_dash || edge ? kMarking : kAsphalt;
      break;
    }
    case Surface::Sidewalk: c = kPavement; break;
    case Surface::Facade: c = facade_colour(info.id, x, z); break;
    case Surface::Car: c = kCarColours[info.id % 6]; break;
  }
  (void)y;
  const uint64_t key = key_of(v[0], v[1], v[2]);
  for (size_t ch = 0; ch < 3; ++ch) c[ch] = std::clamp(c[ch] + 0.05f * hash_noise(key, ch), 0.0f, 1.0f);
  return c;
}

// A ray that misses the voxels: the road beyond them, far facades, a backdrop or the sky. Returns false
// for the sky (colour = sky gradient).
bool background_colour(const std::array<double, 3>& o, const std::array<double, 3>& d, Rgb& c) {
  double best = std::numeric_limits<double>::infinity();
  auto hit = [&](double t, const Rgb& colour) {
    if (t > 1e-6 && t < best) {
      best = t;
      c = colour;
    }
  };
  if (d[2] < 0.0) {  // the ground plane z = 0
    const double t = -o[2] / d[2], y = o[1] + t * d[1];
    hit(t, std::abs(y) < 6.0 ? kAsphalt : (std::abs(y) < kFacadeY ? kPavement : Rgb{0.42f, 0.45f, 0.36f}));
  }
  if (d[1] != 0.0) {
    for (double side : {-1.0, 1.0}) {
      // Far facades, past the voxels (x >= 80 m, up to 12 m), and a backdrop behind the alleys at 20 m.
      const double tf = (side * kFacadeY - o[1]) / d[1], xf = o[0] + tf * d[0], zf = o[2] + tf * d[2];
      if (xf >= 80.0 && zf >= 0.0 && zf <= 12.0) hit(tf, facade_colour(side > 0 ? 9 : 10, xf, zf));
      const double tb = (side * 20.0 - o[1]) / d[1], xb = o[0] + tb * d[0], zb = o[2] + tb * d[2];
      if (zb >= 0.0 && zb <= 20.0) hit(tb, facade_colour(side > 0 ? 11 : 12, xb, zb));
    }
  }
  if (d[0] > 0.0) {  // distant buildings at x = 200 m, 6 m high
    const double t = (200.0 - o[0]) / d[0], z = o[2] + t * d[2];
    if (z >= 0.0 && z <= 6.0) hit(t, Rgb{0.48f, 0.50f, 0.54f});
  }
  if (best < std::numeric_limits<double>::infinity()) return true;
  const float e = static_cast<float>(std::clamp(3.0 * d[2], 0.0, 1.0));
  c = {0.75f + (0.35f - 0.75f) * e, 0.82f + (0.55f - 0.82f) * e, 0.92f + (0.85f - 0.92f) * e};
  return false;
}

}  // namespace

nn::GsmInputs street_scene(int64_t views, int64_t height, int64_t width, uint32_t seed) {
  if (views < 1 || height < 16 || width < 16 || height % 16 || width % 16)
    throw std::invalid_argument("street scene: views >= 1 and an image size of multiples of 16 (got " +
                                std::to_string(height) + " x " + std::to_string(width) + ")");
  const Street street = build_street();
  nn::GsmInputs in;
  in.batch = 1;
  in.views = views;
  in.height = height;
  in.width = width;
  in.voxel_ijk = {street.voxels};
  const float fx = 2055.0f * static_cast<float>(width) / 1920.0f, fy = 2055.0f * static_cast<float>(height) / 1280.0f;
  for (int64_t n = 0; n < views; ++n) {
    // Camera-to-grid: camera x (right) = -y, camera y (down) = -z, camera z (forward) = +x.
    const float tx = 5.0f * static_cast<float>(n), ty = -2.0f, tz = 2.0f;
    in.poses.push_back({0, 0, 1, tx, -1, 0, 0, ty, 0, -1, 0, tz, 0, 0, 0, 1});
    in.intrinsics.push_back({fx, fy, 0.5f * static_cast<float>(width), 0.5f * static_cast<float>(height),
                             static_cast<float>(width), static_cast<float>(height)});
  }
  const nn::VoxelRayGrid grid(nn::gsm_input_grid(in, 0));
  const int64_t px = height * width;
  in.images = nn::CpuTensor({1, views, height, width, 3});
  in.masks.assign(static_cast<size_t>(views * px * 4), 0);
  for (int64_t n = 0; n < views; ++n) {
    const std::array<float, 16>& pose = in.poses[static_cast<size_t>(n)];
    const std::array<double, 3> o{pose[3], pose[7], pose[11]};
    for (int64_t v = 0; v < height; ++v)
      for (int64_t u = 0; u < width; ++u) {
        const std::array<float, 3> df = nn::gsm_pixel_ray_direction(pose, in.intrinsics[static_cast<size_t>(n)], u, v);
        const std::array<double, 3> d{df[0], df[1], df[2]};
        const nn::VoxelRayWalk walk = grid.march(o, d);
        Rgb c{};
        bool solid = true;
        if (walk.first_voxel >= 0)
          c = voxel_colour(street, street.voxels[static_cast<size_t>(walk.first_voxel)]);
        else
          solid = background_colour(o, d, c);
        const size_t p = static_cast<size_t>(n * px + v * width + u);
        const uint64_t pixel_key = static_cast<uint64_t>(p) + static_cast<uint64_t>(seed) * 0x100000000ull;
        for (size_t ch = 0; ch < 3; ++ch)
          in.images.data[p * 3 + ch] = std::clamp(c[ch] + 0.01f * hash_noise(pixel_key, 7 + ch), 0.0f, 1.0f);
        in.masks[p * 4 + 0] = solid ? 1 : 0;
        in.masks[p * 4 + 1] = 1;
        in.masks[p * 4 + 2] = 1;
      }
  }
  std::mt19937 rng(seed);
  std::bernoulli_distribution keep(0.5);
  in.depth_patch_keep.resize(static_cast<size_t>(views * (height / 16) * (width / 16)));
  for (uint8_t& k : in.depth_patch_keep) k = keep(rng) ? 1 : 0;
  return in;
}

nn::GsmInputs first_views(const nn::GsmInputs& in, int64_t views) {
  if (in.batch != 1 || views < 1 || views > in.views)
    throw std::invalid_argument("first_views: " + std::to_string(views) + " of a batch-1 scene of " + std::to_string(in.views) + " views");
  nn::GsmInputs out = in;
  out.views = views;
  const size_t px = static_cast<size_t>(in.height * in.width), patches = static_cast<size_t>(in.patch_rows() * in.patch_cols());
  const size_t n = static_cast<size_t>(views);
  out.images = nn::CpuTensor({1, views, in.height, in.width, 3},
                             std::vector<float>(in.images.data.begin(), in.images.data.begin() + static_cast<std::ptrdiff_t>(n * px * 3)));
  out.masks.assign(in.masks.begin(), in.masks.begin() + static_cast<std::ptrdiff_t>(n * px * 4));
  out.poses.assign(in.poses.begin(), in.poses.begin() + static_cast<std::ptrdiff_t>(n));
  out.intrinsics.assign(in.intrinsics.begin(), in.intrinsics.begin() + static_cast<std::ptrdiff_t>(n));
  out.depth_patch_keep.assign(in.depth_patch_keep.begin(), in.depth_patch_keep.begin() + static_cast<std::ptrdiff_t>(n * patches));
  return out;
}

}  // namespace icube::bench

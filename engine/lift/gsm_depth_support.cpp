// The voxels the GSM's depth prior depends on; see gsm_depth_support.h.
#include "lift/gsm_depth_support.h"

#include "nn/gsm/gsm_rays.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <unordered_set>

namespace icube::lift {

namespace {

uint64_t pack(int64_t i, int64_t j, int64_t k) {
  constexpr int64_t bias = int64_t(1) << 20;
  return uint64_t(i + bias) | (uint64_t(j + bias) << 21) | (uint64_t(k + bias) << 42);
}

// Every cell of `grid` the ray o + t d meets for t in [0, t_end] (cells [0.2 ijk, 0.2 (ijk + 1)]; the
// GSM grid's origin 0.1 m is the centre of cell 0), and on a tie between crossings both ways round.
void add_cells_along(const std::array<double, 3>& o, const std::array<double, 3>& d, double t_end,
                     const std::unordered_set<uint64_t>& grid, std::unordered_set<uint64_t>& out) {
  constexpr double vs = nn::kGsmVoxelSize, tie = 1e-7;  // metres along the ray
  constexpr double inf = std::numeric_limits<double>::infinity();
  std::array<int64_t, 3> c{}, step{};
  std::array<double, 3> next{}, delta{};
  for (size_t a = 0; a < 3; ++a) {
    c[a] = int64_t(std::floor(o[a] / vs));
    if (d[a] > 0.0) {
      step[a] = 1, next[a] = (double(c[a] + 1) * vs - o[a]) / d[a], delta[a] = vs / d[a];
    } else if (d[a] < 0.0) {
      step[a] = -1, next[a] = (double(c[a]) * vs - o[a]) / d[a], delta[a] = -vs / d[a];
    } else {
      step[a] = 0, next[a] = inf, delta[a] = inf;
    }
  }
  auto add = [&](int64_t i, int64_t j, int64_t k) {
    const uint64_t key = pack(i, j, k);
    if (grid.count(key)) out.insert(key);
  };
  for (int guard = 0; guard < 1 << 22; ++guard) {
    add(c[0], c[1], c[2]);
    const double t = std::min({next[0], next[1], next[2]});
    if (!(t <= t_end)) return;
    // Crossings within `tie` of the first: the cells of every other order of taking them.
    std::array<bool, 3> tied{};
    int ties = 0;
    for (size_t a = 0; a < 3; ++a) ties += (tied[a] = next[a] - t <= tie) ? 1 : 0;
    if (ties > 1)
      for (int mask = 1; mask < 7; ++mask) {
        bool ok = true;
        int bits = 0;
        for (size_t a = 0; a < 3; ++a)
          if (mask & (1 << a)) ok = ok && tied[a], ++bits;
        if (ok && bits < ties)
          add(c[0] + ((mask & 1) ? step[0] : 0), c[1] + ((mask & 2) ? step[1] : 0), c[2] + ((mask & 4) ? step[2] : 0));
      }
    const size_t a = size_t(std::min_element(next.begin(), next.end()) - next.begin());
    c[a] += step[a];
    next[a] += delta[a];
  }
}

}  // namespace

std::vector<nn::Ijk> gsm_depth_support(const nn::GsmInputs& in, int64_t b) {
  const nn::SparseGrid g = nn::gsm_input_grid(in, b);
  const nn::VoxelRayGrid walker(g);
  std::unordered_set<uint64_t> grid;
  grid.reserve(g.ijk.size() * 2);
  for (const nn::Ijk& v : g.ijk) grid.insert(pack(v[0], v[1], v[2]));
  std::unordered_set<uint64_t> out;
  const int64_t N = in.views, H = in.height, W = in.width;
  for (int64_t view = 0; view < N; ++view) {
    const std::array<float, 16>& pose = in.poses[size_t(b * N + view)];
    const std::array<float, 6>& k = in.intrinsics[size_t(b * N + view)];
    const std::array<double, 3> centre{pose[3], pose[7], pose[11]};
    for (int64_t v = 0; v < H; ++v)
      for (int64_t u = 0; u < W; ++u) {
        const std::array<float, 3> df = nn::gsm_pixel_ray_direction(pose, k, u, v);
        const std::array<double, 3> d{df[0], df[1], df[2]};
        const double t0 = walker.march(centre, d).first_segment_start(nn::kGsmDepthMinSegment);
        if (t0 < 0.0) continue;
        add_cells_along(centre, d, t0 + nn::kGsmDepthMinSegment + nn::kGsmVoxelSize, grid, out);
      }
  }
  std::vector<nn::Ijk> ijk;
  ijk.reserve(out.size());
  for (const nn::Ijk& v : g.ijk)
    if (out.count(pack(v[0], v[1], v[2]))) ijk.push_back(v);
  std::sort(ijk.begin(), ijk.end());
  return ijk;
}

}  // namespace icube::lift

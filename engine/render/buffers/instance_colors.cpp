// PuRd LUT and seeded instance colours; see instance_colors.h.
#include "render/buffers/instance_colors.h"

#include <algorithm>
#include <cmath>
#include <random>

namespace icube::render {

namespace {

constexpr uint32_t kPuRd9[9] = {0xf7f4f9, 0xe7e1ef, 0xd4b9da, 0xc994c7, 0xdf65b0,
                                0xe7298a, 0xce1256, 0x980043, 0x67001f};

std::array<Rgb8, 256> build_lut() {
  constexpr int kN = 256, kA = 9;
  std::array<Rgb8, 256> lut{};
  // Anchor positions: numpy linspace(0, 1, 9) = i * 0.125, times N - 1.
  double x[kA];
  for (int i = 0; i < kA; ++i) x[i] = (static_cast<double>(i) * (1.0 / 8.0)) * (kN - 1);
  for (int c = 0; c < 3; ++c) {
    double y[kA];
    for (int i = 0; i < kA; ++i) y[i] = static_cast<double>((kPuRd9[i] >> (16 - 8 * c)) & 0xffu) / 255.0;
    for (int i = 0; i < kN; ++i) {
      double v;
      if (i == 0) {
        v = y[0];
      } else if (i == kN - 1) {
        v = y[kA - 1];
      } else {
        const double xi = (kN - 1) * (static_cast<double>(i) * (1.0 / (kN - 1)));
        int ind = 0;  // searchsorted left: first x[ind] >= xi
        while (ind < kA && x[ind] < xi) ++ind;
        const double dist = (xi - x[ind - 1]) / (x[ind] - x[ind - 1]);
        v = dist * (y[ind] - y[ind - 1]) + y[ind - 1];
      }
      v = std::clamp(v, 0.0, 1.0);
      lut[static_cast<size_t>(i)][static_cast<size_t>(c)] = static_cast<uint8_t>(v * 255.0);  // truncation
    }
  }
  return lut;
}

}  // namespace

const std::array<Rgb8, 256>& purd_lut() {
  static const std::array<Rgb8, 256> lut = build_lut();
  return lut;
}

std::map<uint16_t, Rgb8> instance_colors(const std::vector<uint16_t>& unique_ids, uint64_t seed) {
  std::vector<uint16_t> ids(unique_ids);
  std::sort(ids.begin(), ids.end());
  ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
  std::mt19937_64 rng(seed);
  std::map<uint16_t, Rgb8> out;
  for (uint16_t id : ids) {
    if (id == 0) continue;
    const double u = static_cast<double>(rng() >> 11) * 0x1.0p-53;
    const int idx = std::min(255, static_cast<int>(u * 256.0));
    out[id] = purd_lut()[static_cast<size_t>(idx)];
  }
  return out;
}

}  // namespace icube::render

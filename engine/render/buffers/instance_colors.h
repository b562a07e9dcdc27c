// Instance colours of the semantic guidance buffer (conventions §5):
// matplotlib's PuRd colour map as a 256-entry LUT and one colour per unique
// instance id drawn from a seeded generator.
//
// LUT: the 9 ColorBrewer PuRd-9 anchors (#f7f4f9 … #67001f), each channel c/255
// at x = linspace(0, 1, 9), interpolated at x_i = 255·(i·(1/255)) exactly as
// LinearSegmentedColormap.from_list(…, N = 256) builds its table (in double,
// searchsorted-left segments), then × 255 truncated to uint8.
// Colouring: the unique ids > 0 of a whole sequence in increasing order each
// draw u ~ U[0, 1) from std::mt19937_64(seed) as (next() >> 11) · 2^-53;
// colour = LUT[min(floor(u · 256), 255)] (matplotlib's cmap(u)). Upstream
// draws unseeded; ours is reproducible. Ids >= 2^15 would use YlOrBr upstream
// (never used: instance ids stay below that); we use PuRd for every id.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <vector>

namespace icube::render {

using Rgb8 = std::array<uint8_t, 3>;

// The 256-entry PuRd LUT (index 0 = (247,244,249), 255 = (103,0,31)).
const std::array<Rgb8, 256>& purd_lut();

// id -> colour for the sorted unique ids (0 is ignored).
std::map<uint16_t, Rgb8> instance_colors(const std::vector<uint16_t>& unique_ids, uint64_t seed);

}  // namespace icube::render

// Body of primitives/radix_count32.comp / primitives/radix_count64.comp (see their headers).
#include "shared/primitives_params.h"
#include "common/dispatch.glsl"
#include "primitives/radix_common.glsl"

layout(local_size_x_id = 0) in;
layout(constant_id = 1) const uint TILE = 4096;

layout(push_constant) uniform Push { RadixParams p; };
layout(std430, binding = 0) readonly buffer Keys { KEY_T keys[]; };
layout(std430, binding = 1) writeonly buffer Hist { uint hist[]; };

shared uint counts[RADIX_SIZE];

void main() {
  uint tile = p.tile_first + icube_group_linear();
  if (tile >= p.num_tiles) return;
  const uint window_base = p.tile_first * TILE;  // element index of keys[0] (the bound window)
  uint lane = gl_SubgroupInvocationID;
  for (uint d = lane; d < RADIX_SIZE; d += gl_SubgroupSize) counts[d] = 0u;
  subgroupBarrier();

  uint begin = tile * TILE;
  uint end = min(begin + TILE, p.n);
  for (uint base = begin; base < end; base += gl_SubgroupSize) {
    uint i = base + lane;
    bool valid = i < end;
    uint d = valid ? key_digit(keys[i - window_base], p.shift) & p.digit_mask : 0u;
    uvec4 match = match_digit(d, valid);
    if (valid && subgroupBallotFindMSB(match) == lane) counts[d] += subgroupBallotBitCount(match);
    subgroupBarrier();  // the next batch's leader for d may be another lane
  }
  for (uint d = lane; d < RADIX_SIZE; d += gl_SubgroupSize) hist[d * p.num_tiles + tile] = counts[d];
}

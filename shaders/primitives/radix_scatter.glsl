// Body of primitives/radix_scatter32.comp / primitives/radix_scatter64.comp (see their headers).
#include "shared/primitives_params.h"
#include "common/dispatch.glsl"
#include "primitives/radix_common.glsl"

layout(local_size_x_id = 0) in;
layout(constant_id = 1) const uint TILE = 4096;

layout(push_constant) uniform Push { RadixParams p; };
layout(std430, binding = 0) readonly buffer KeysIn { KEY_T keys_in[]; };
layout(std430, binding = 1) readonly buffer ValuesIn { uint values_in[]; };
layout(std430, binding = 2) readonly buffer Offsets { uint offsets[]; };
layout(std430, binding = 3) writeonly buffer KeysOut { KEY_T keys_out[]; };
layout(std430, binding = 4) writeonly buffer ValuesOut { uint values_out[]; };

shared uint next_slot[RADIX_SIZE];

void main() {
  uint tile = p.tile_first + icube_group_linear();
  if (tile >= p.num_tiles) return;
  const uint window_base = p.tile_first * TILE;  // element index of keys_in[0] (the bound window)
  uint lane = gl_SubgroupInvocationID;
  for (uint d = lane; d < RADIX_SIZE; d += gl_SubgroupSize) next_slot[d] = offsets[d * p.num_tiles + tile];
  subgroupBarrier();

  uint begin = tile * TILE;
  uint end = min(begin + TILE, p.n);
  for (uint base = begin; base < end; base += gl_SubgroupSize) {
    uint i = base + lane;
    bool valid = i < end;
    KEY_T key;
    uint value = 0u;
    uint d = 0u;
    if (valid) {
      key = keys_in[i - window_base];
      value = values_in[i - window_base];
      d = key_digit(key, p.shift) & p.digit_mask;
    }
    uvec4 match = match_digit(d, valid);
    uint leader = subgroupBallotFindMSB(match);
    bool is_leader = valid && leader == lane;
    // Only the leader reads the running offset; the shuffle hands it to the
    // group, so the leader's update below cannot race with other lanes' reads.
    uint slot = is_leader ? next_slot[d] : 0u;
    uint group_base = subgroupShuffle(slot, leader);
    if (valid) {
      // Destinations outside the bound window are written by this tile's dispatch for their window.
      const uint dst = group_base + subgroupBallotExclusiveBitCount(match) - p.dst_first;
      if (dst < p.dst_count) {
        keys_out[dst] = key;
        values_out[dst] = value;
      }
    }
    if (is_leader) next_slot[d] = slot + subgroupBallotBitCount(match);
    subgroupBarrier();  // the next batch's leader for d may be another lane
  }
}

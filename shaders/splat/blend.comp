#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_vote : require
#extension GL_KHR_shader_subgroup_ballot : require
#extension GL_KHR_shader_subgroup_shuffle : require
#extension GL_KHR_shader_subgroup_arithmetic : require
// splat_blend: front-to-back alpha blending per pixel over the pixel's tile
// range of the sorted instance list (rules and thresholds in
// engine/splat/rasterizer_cpu.h: skip power > 0 and α < 1/255, α ≤ 0.99, stop
// before T·(1−α) < 1e-4, per pixel).
// Layout: one workgroup per tile (tile = linear workgroup id: the tile's range
// is uniform). One invocation blends P = SPLAT_BLEND_PIXELS (splat_params.h)
// consecutive pixels of one tile row in registers; S = 16/P segments per row,
// 16·S invocations per workgroup: invocation l covers row (l & 7) +
// 8·((l >> 3) / S), columns P·((l >> 3) % S) + [0, P), so 8 consecutive
// invocations (lavapipe's subgroup) cover a P × 8 block. The P pixels are
// SPLAT_BLEND_GROUPS column groups of G = SPLAT_BLEND_G columns (G × the
// subgroup's rows: the unit of skipping; G = 8 and U = 4 measured fastest on
// lavapipe, bench/README.md).
// Batches: each lane loads SPLAT_BLEND_SLOTS blend records (slot s: instance
// base + s·stride + lane; independent loads, so their cache misses overlap)
// and tests each one's α-cut ellipse (dᵀ·conic·d <= −2·log_cut, log_cut =
// ln(0.9/(255·o)), the 10 % margin) against the subgroup's rows grown by 1/4 px
// (the slab test of splat/tiles.glsl), then against each column group
// grown by 1/4 px with the chord's extreme x over those rows (the 10 % α margin
// alone is ≥ 0.017 px at the cut for the narrowest Gaussian the 0.3 px²
// dilation allows, far above the chord's float error of ~1e-4 px; the 1/4 px
// is spare). One ballot word per group holds the batch's needed entries (bit s·stride + lane: bit order is
// depth order). Then, group by group, a loop over the group's bits evaluates
// SPLAT_BLEND_UNROLL needed Gaussians per iteration on the group's G pixels of
// every lane, the derived values selected from the entry's slot and shuffled
// from its lane (uniform); past the last bit an entry blends nothing.
// Skipped Gaussians cannot pass the per-pixel tests on the skipped pixels, so
// the skips do not change the result. Why loops per group and not ifs: Mesa's
// gallivm (lavapipe) executes every if, even a uniform one, under a lane
// mask, so only a loop's trip count skips work. gallivm tests a loop's exit at
// the end of its body: a while loop or a break runs the rest of the body once
// more, masked, when it ends, so every loop here is a do-while whose condition
// (more entries and, by a subgroup vote, a live pixel) is its last statement,
// and the U Gaussians of an iteration share its vote, loop control and masked
// state writes (their selects and exp2s overlap). On CPU devices (spec
// constant SPLAT_LANES = the subgroup size) the ballots and votes OR the lanes'
// words fetched by constant-index shuffles (common/lane_shuffles.glsl: one vpermd each), since
// lavapipe's subgroupBallot / subgroupAny are scalar loops over the lanes; GPUs
// (SPLAT_LANES = 0) use the intrinsics. No shared memory or barriers (slow on
// lavapipe). The spec constant SPLAT_DEPTH = false leaves the depth outputs
// out (SplatOptions::depth). A frame in depth slices (SPLAT_CARRY, p.carry)
// starts each pixel from the nearer slices' state and passes its own on
// (bindings 7, 8).
// Numerics: per Gaussian (once per batch entry and lane) A = −½·a·log2e,
// B = −b·log2e, C = −½·c·log2e and log2 o; per pixel q = dx·(A·dx + B·dy) +
// C·dy² + log2 o (= log2(o·e^power); the dy terms once per Gaussian and lane),
// α = min(0.99, 2^q); the reference's skips power > 0 and α < 1/255 are
// q > log2 o and q < log2(1/255); test_t = T·(1−α), w = α·T and the stop rule
// as in the reference. So α differs from the reference's o·e^power by rounding
// (the tests' max interior difference stays ~1.5e-5); a threshold decided on
// q instead of α flips for a few more pixels at the 1/255 and 1e-4 boundaries
// (the degenerate-Gaussians test: 31 instead of 22 of 4800 pixels beyond
// 1e-3; the other tests 0), for ~8 % of the blend time against α = o·2^(q −
// log2 o). T > 0 marks a live pixel, T < 0 a stopped one with transmittance
// −T (pixels outside the image start stopped). Median depth: each Gaussian
// blended while T > 0.5 overwrites it, and a pixel whose transmittance stays
// above 0.5 reports 0, which is the reference's "the Gaussian that takes T to
// ≤ 0.5" with one compare less per pixel and Gaussian.
// Host module: engine/splat/rasterizer_gpu.cpp; tests: tests/splat/test_splat.cpp.
#include "shared/splat_params.h"
#include "common/dispatch.glsl"
#include "common/lane_shuffles.glsl"

#define SPLAT_BLEND_SEGS (SPLAT_TILE / SPLAT_BLEND_PIXELS)  // segments per tile row
#define SPLAT_BLEND_PER_TILE (SPLAT_TILE * SPLAT_BLEND_SEGS)  // invocations per tile

layout(local_size_x_id = 0) in;
// false: leave out the expected and median depth (their state, updates and stores).
layout(constant_id = 1) const bool SPLAT_DEPTH = true;
// CPU devices (lavapipe): the subgroup size, and the kernel's ballots and votes OR the lanes'
// words fetched by constant-index shuffles (one vpermd each on lavapipe, where subgroupBallot
// and subgroupAny are scalar loops over the lanes with a store and a branch per lane). 0 (GPUs):
// subgroupBallot / subgroupAny.
layout(constant_id = 2) const uint SPLAT_LANES = 0;
// true: a frame in depth slices (p.carry says in and out); false (one pass) leaves the carry
// code out, so one-pass frames run the same code as before slices existed.
layout(constant_id = 3) const bool SPLAT_CARRY = false;
layout(push_constant) uniform Push { SplatBlendParams p; };
layout(std430, binding = 0) readonly buffer Ranges { uvec2 ranges[]; };
// Divergent (per-lane) loads go through texel buffers: on lavapipe a texel fetch is a
// gather, a storage-buffer load at a divergent address a per-lane loop. Records are
// fetched as R32G32B32A32_UINT and bit-cast (exact on every driver).
layout(binding = 1) uniform usamplerBuffer values;   // R32_UINT: sorted instance Gaussian ids
layout(binding = 2) uniform usamplerBuffer records;  // R32G32B32A32_UINT: 3 texels per SplatBlendRecord
layout(std430, binding = 3) writeonly buffer Rgba { vec4 rgba[]; };
layout(std430, binding = 4) writeonly buffer Depth { vec2 depth[]; };
layout(binding = 5) uniform usamplerBuffer sky_texels;  // R32_UINT: RGBA8 sky texels
// Tiles whose loops reached p.loop_budget (see below); zeroed by the host before the blend.
layout(std430, binding = 6) buffer Status { uint status; };
// A frame in depth slices (p.carry, engine/splat/depth_slices.h): each pixel's blend state
// between slices, (C, T) and (Σ depth·w, median). Nearer slices blend first, so the pixel sees
// the whole frame's Gaussians in the same order and the same operations as in one pass.
layout(std430, binding = 7) buffer CarryColor { vec4 carry_color[]; };
layout(std430, binding = 8) buffer CarryDepth { vec2 carry_depth[]; };

vec3 sky_texel(int x, int y) { return unpackUnorm4x8(texelFetch(sky_texels, int(uint(y) * p.sky_w + uint(x))).x).xyz; }
vec4 record(uint t) { return uintBitsToFloat(texelFetch(records, int(t))); }

// Mirrors engine/splat/sky.cpp sky_ray_dir + sky_color operation by operation.
vec3 splat_sky(float px, float py) {
  if (p.sky_kind == SPLAT_SKY_BACKGROUND) return vec3(p.bg_r, p.bg_g, p.bg_b);
  const float x = p.m00 * px + p.m01 * py + p.m02;
  const float y = p.m10 * px + p.m11 * py + p.m12;
  const float z = p.m20 * px + p.m21 * py + p.m22;
  const float inv = 1.0 / sqrt(x * x + y * y + z * z);
  const vec3 d = vec3(x * inv, y * inv, z * inv);
  if (p.sky_kind == SPLAT_SKY_GRADIENT) {
    const vec3 hor = vec3(p.hor_r, p.hor_g, p.hor_b);
    if (d.z >= 0.0) return hor + (vec3(p.zen_r, p.zen_g, p.zen_b) - hor) * d.z;
    return hor + (vec3(p.gnd_r, p.gnd_g, p.gnd_b) - hor) * (-d.z);
  }
  const float kPi = 3.14159265358979;
  const float lon = atan(d.y, d.x);
  const float theta = atan(sqrt(d.x * d.x + d.y * d.y), d.z);
  const float sx = (0.5 - lon / (2.0 * kPi)) * float(p.sky_w) - 0.5;
  const float sy = (theta / kPi) * float(p.sky_h) - 0.5;
  const float xf = floor(sx), yf = floor(sy);
  const float ax = sx - xf, ay = sy - yf;
  const int W = int(p.sky_w), H = int(p.sky_h);
  const int xi = int(xf);
  const int x0 = xi < 0 ? xi + W : (xi >= W ? xi - W : xi), x1 = x0 + 1 == W ? 0 : x0 + 1;
  const int y0 = clamp(int(yf), 0, H - 1), y1 = clamp(int(yf) + 1, 0, H - 1);
  const vec3 top = sky_texel(x0, y0) * (1.0 - ax) + sky_texel(x1, y0) * ax;
  const vec3 bot = sky_texel(x0, y1) * (1.0 - ax) + sky_texel(x1, y1) * ax;
  return top * (1.0 - ay) + bot * ay;
}

uint lanes_ballot(bool c) {
  if (SPLAT_LANES == 0u) return subgroupBallot(c).x;
  return lanes_shuffle_or(c ? 1u << gl_SubgroupInvocationID : 0u, SPLAT_LANES);
}
bool lanes_any(bool c) {
  if (SPLAT_LANES == 0u) return subgroupAny(c);
  return lanes_shuffle_or(c ? 1u : 0u, SPLAT_LANES) != 0u;
}

// Pixels of one column group (a uniform skip unit): the invocation's P pixels are
// SPLAT_BLEND_GROUPS groups of G consecutive columns.
#ifndef SPLAT_BLEND_G
#define SPLAT_BLEND_G 8
#endif
#define SPLAT_BLEND_GROUPS (SPLAT_BLEND_PIXELS / SPLAT_BLEND_G)
#if SPLAT_BLEND_GROUPS != 1 && SPLAT_BLEND_GROUPS != 2 && SPLAT_BLEND_GROUPS != 4
#error "main() expands SPLAT_BLEND_GROUP for 1, 2 or 4 column groups"
#endif
// Records per lane per batch (slot s of lane l holds instance base + s·stride + l; batch
// bit s·stride + l, so bit order is depth order). Capped at runtime so that slots ·
// stride <= 32 (one ballot word).
#ifndef SPLAT_BLEND_SLOTS
#define SPLAT_BLEND_SLOTS 4
#endif

const float kLog2e = 1.4426950408889634;
const float kQMin = -7.9943534368588579;  // log2(1/255)
const float kNoEntry = -1.0e30;  // log2 o of "no entry": q <= -1e30 fails q >= kQMin

// Gaussians per group-loop iteration: their record selects and exp2s are independent, so
// they overlap, and the iteration's fixed cost (vote, loop control, the masked writes of the
// group's pixel state) is paid once for U Gaussians.
#ifndef SPLAT_BLEND_UNROLL
#define SPLAT_BLEND_UNROLL 4
#endif

// The next needed Gaussian of `mask` (its lowest bit; depth order) into H0 = (mx, my, A, B),
// H1 = (C, log2 o, depth), RGB: selected from the entry's slot and shuffled from its lane
// (uniform). With no bit left, H1.y = log2 o = −1e30: q ≈ −1e30 fails q >= kQMin on every
// pixel, so the entry blends nothing.
#define SPLAT_BLEND_TAKE(H0, H1, RGB)                                 \
  {                                                                   \
    const uint e = uint(findLSB(mask)); /* 0xFFFFFFFF when mask == 0 */ \
    mask &= mask - 1u;                                                \
    const uint s = e >> lane_bits, src = e & (stride - 1u);           \
    H0 = d0[0];                                                       \
    H1 = d1[0];                                                       \
    RGB = d2[0];                                                      \
    for (int t = 1; t < SPLAT_BLEND_SLOTS; ++t)                       \
      if (s == uint(t)) {                                             \
        H0 = d0[t];                                                   \
        H1 = d1[t];                                                   \
        RGB = d2[t];                                                  \
      }                                                               \
    H0 = subgroupShuffle(H0, src);                                    \
    H1 = subgroupShuffle(H1, src);                                    \
    RGB = subgroupShuffle(RGB, src);                                  \
    H1.y = e == 0xFFFFFFFFu ? kNoEntry : H1.y;                       \
  }

// One Gaussian (H0, H1, RGB as above) blended into the G pixels of column group GRP.
#define SPLAT_BLEND_APPLY(GRP, H0, H1, RGB)                                  \
  {                                                                          \
    const float dy = H0.y - py;                                              \
    const float by = H0.w * dy, hy = H1.x * dy * dy + H1.y;                  \
    for (int jj = 0; jj < SPLAT_BLEND_G; ++jj) {                             \
      const int j = GRP * SPLAT_BLEND_G + jj;                                \
      const float dx = H0.x - (px0 + float(j));                              \
      const float q = dx * (H0.z * dx + by) + hy;                            \
      const float alpha = min(0.99, exp2(q));                                \
      const bool ok = T[j] > 0.0 && q >= kQMin && q <= H1.y;                 \
      const float test_t = T[j] * (1.0 - alpha);                             \
      const bool stop = ok && test_t < 1e-4;                                 \
      const bool use = ok && !stop;                                          \
      const float w = use ? alpha * T[j] : 0.0;                              \
      C[j] += RGB * w;                                                       \
      if (SPLAT_DEPTH) {                                                     \
        wz[j] += H1.z * w;                                                   \
        median[j] = use && T[j] > 0.5 ? H1.z : median[j];                    \
      }                                                                      \
      T[j] = stop ? -T[j] : (use ? test_t : T[j]);                           \
    }                                                                        \
  }

// Whether any lane has a live pixel among pixels [FIRST, FIRST + COUNT) (a subgroup vote).
#define SPLAT_BLEND_ANY_LIVE(FIRST, COUNT, OUT)                           \
  {                                                                       \
    float live = T[FIRST];                                                \
    for (int jj = 1; jj < COUNT; ++jj) live = max(live, T[FIRST + jj]);   \
    OUT = lanes_any(live > 0.0);                                          \
  }

// The needed Gaussians of column group GRP (bits of gmask[GRP], depth order), U per
// iteration: all U taken first, then applied in depth order (Gaussian by Gaussian over the
// group's pixels, whose T chains then overlap). A do-while: gallivm tests a loop's exit at
// the end of its body, so a while loop (or a break) runs the rest of the body once more,
// masked, when it ends; a do-while whose condition is its last statement ends without that.
// It runs once with no needed Gaussian (entries blend nothing). It stops when no pixel of
// the group is live.
#define SPLAT_BLEND_GROUP(GRP)                                                          \
  {                                                                                     \
    uint mask = gmask[GRP];                                                             \
    bool more;                                                                          \
    do {                                                                                \
      ++iters;                                                                          \
      vec4 h0[SPLAT_BLEND_UNROLL], h1[SPLAT_BLEND_UNROLL];                              \
      vec3 hc[SPLAT_BLEND_UNROLL];                                                      \
      for (int u = 0; u < SPLAT_BLEND_UNROLL; ++u) SPLAT_BLEND_TAKE(h0[u], h1[u], hc[u]) \
      for (int u = 0; u < SPLAT_BLEND_UNROLL; ++u) SPLAT_BLEND_APPLY(GRP, h0[u], h1[u], hc[u]) \
      SPLAT_BLEND_ANY_LIVE(GRP * SPLAT_BLEND_G, SPLAT_BLEND_G, more)                     \
    } while (mask != 0u && more);                                                       \
  }

void main() {
  const uint tile = icube_group_linear();  // uniform: one tile per workgroup
  if (tile >= p.grid_x * p.grid_y) return;
  const uint local = gl_LocalInvocationID.x;
  const uint u0 = (tile % p.grid_x) * SPLAT_TILE + ((local >> 3) % SPLAT_BLEND_SEGS) * SPLAT_BLEND_PIXELS;
  const uint v = (p.tile_y0 + tile / p.grid_x) * SPLAT_TILE + (local & 7u) + 8u * ((local >> 3) / SPLAT_BLEND_SEGS);
  const float py = float(v) + p.pixel_offset;
  const float px0 = float(u0) + p.pixel_offset;  // sample x of the segment's first pixel
  // The subgroup's pixel block (sample coordinates), grown by 1/4 px: uniform.
  const float bxs = subgroupMin(px0);
  const float by0 = subgroupMin(py) - 0.25, by1 = subgroupMax(py) + 0.25;
  const uint lanes = subgroupBallotBitCount(subgroupBallot(true));  // active lanes: 0 .. lanes-1
  const uint lane = gl_SubgroupInvocationID;
  // Batch lanes: the largest power of two <= lanes (lanes <= 16: one tile per workgroup).
  const uint lane_bits = uint(findMSB(lanes)), stride = 1u << lane_bits;
  const uint slots = min(uint(SPLAT_BLEND_SLOTS), 32u >> lane_bits);
  float T[SPLAT_BLEND_PIXELS], wz[SPLAT_BLEND_PIXELS], median[SPLAT_BLEND_PIXELS];
  vec3 C[SPLAT_BLEND_PIXELS];
  for (int j = 0; j < SPLAT_BLEND_PIXELS; ++j) {
    T[j] = u0 + uint(j) < p.width && v < p.height ? 1.0 : -1.0;
    wz[j] = 0.0;
    median[j] = 0.0;
    C[j] = vec3(0.0);
    const uint u = u0 + uint(j);
    if (SPLAT_CARRY && (p.carry & SPLAT_CARRY_IN) != 0u && u < p.width && v < p.height) {
      const uint pix = (v - p.tile_y0 * SPLAT_TILE) * p.width + u;
      const vec4 c = carry_color[pix];
      C[j] = c.xyz;
      T[j] = c.w;
      if (SPLAT_DEPTH) {
        wz[j] = carry_depth[pix].x;
        median[j] = carry_depth[pix].y;
      }
    }
  }
  const uvec2 range = ranges[tile];
  // Loop iterations of this invocation (all lanes run the loops together: uniform exits). With
  // p.loop_budget (lavapipe, which silently ends every loop of an invocation after 65,535
  // iterations in all) a tile that reaches the budget is counted in `status`, and the host
  // reports the frame as incomplete instead of returning a cut-short blend.
  uint iters = 0u;
  // A do-while, like the group loops (no masked extra batch at its end); an empty range runs
  // one batch of no entries.
  uint base = range.x;
  bool more;
  do {
    ++iters;
    // This lane's instances of the batch: records, derived values and block tests.
    vec4 d0[SPLAT_BLEND_SLOTS], d1[SPLAT_BLEND_SLOTS];
    vec3 d2[SPLAT_BLEND_SLOTS];
    uint gmask[SPLAT_BLEND_GROUPS];
    for (int g = 0; g < SPLAT_BLEND_GROUPS; ++g) gmask[g] = 0u;
    for (int s = 0; s < SPLAT_BLEND_SLOTS; ++s) {
      const uint k = base + (uint(s) << lane_bits) + lane;
      d0[s] = vec4(0.0);
      d1[s] = vec4(0.0);
      d2[s] = vec3(0.0);
      bool need = false;
      float xl = 0.0, xr = 0.0;
      if (uint(s) < slots && lane < stride && k < range.y) {
        const uint gi = texelFetch(values, int(k)).x;
        const vec4 b0 = record(3u * gi), b1 = record(3u * gi + 1u), b2 = record(3u * gi + 2u);
        const float mx = b0.x, my = b0.y, a = b0.z, b = b0.w, c = b1.x;
        const float R = -2.0 * b1.y;
        const float D = a * c - b * b;
        const float ex = sqrt(R * c / D), ey = sqrt(R * a / D);
        const float lo = max(by0 - my, -ey), hi = min(by1 - my, ey);
        const float dyr = -(b / c) * ex;
        const float yr = min(max(dyr, lo), hi), yl = min(max(-dyr, lo), hi);
        xr = mx + (sqrt(max(0.0, a * R - D * (yr * yr))) - b * yr) / a;
        xl = mx + (-sqrt(max(0.0, a * R - D * (yl * yl))) - b * yl) / a;
        need = !(lo > hi);
        d0[s] = vec4(mx, my, -0.5 * kLog2e * a, -kLog2e * b);
        d1[s] = vec4(-0.5 * kLog2e * c, log2(b1.z), b1.w, 0.0);
        d2[s] = b2.xyz;
      }
      // Column group g spans samples bxs + G·g + [0, G−1], grown by 1/4 px. NaN: needed.
      for (int g = 0; g < SPLAT_BLEND_GROUPS; ++g) {
        const float gx0 = bxs + float(SPLAT_BLEND_G * g) - 0.25;
        const float gx1 = bxs + float(SPLAT_BLEND_G * g + SPLAT_BLEND_G - 1) + 0.25;
        const uint bits = lanes_ballot(need && !(xr < gx0 || xl > gx1));
        gmask[g] |= uint(s) < slots ? bits << (uint(s) << lane_bits) : 0u;
      }
    }
    SPLAT_BLEND_GROUP(0)
#if SPLAT_BLEND_GROUPS > 1
    SPLAT_BLEND_GROUP(1)
#endif
#if SPLAT_BLEND_GROUPS > 2
    SPLAT_BLEND_GROUP(2)
    SPLAT_BLEND_GROUP(3)
#endif
    base += slots << lane_bits;
    SPLAT_BLEND_ANY_LIVE(0, SPLAT_BLEND_PIXELS, more)
  } while (base < range.y && more);
  if (p.loop_budget != 0u && iters >= p.loop_budget && subgroupElect()) atomicAdd(status, 1u);
  if (v >= p.height) return;
  for (int j = 0; j < SPLAT_BLEND_PIXELS; ++j) {
    const uint u = u0 + uint(j);
    if (u >= p.width) break;
    const uint pix = (v - p.tile_y0 * SPLAT_TILE) * p.width + u;
    if (SPLAT_CARRY && (p.carry & SPLAT_CARRY_OUT) != 0u) {  // a nearer slice: the state for the next one
      carry_color[pix] = vec4(C[j], T[j]);
      if (SPLAT_DEPTH) carry_depth[pix] = vec2(wz[j], median[j]);
      continue;
    }
    const float t = abs(T[j]);
    rgba[pix] = vec4(C[j] + t * splat_sky(float(u) + p.pixel_offset, py), 1.0 - t);
    // median[j] holds the depth of the last Gaussian blended while T > 0.5: the one whose blend
    // took T to <= 0.5 (the reference's median), or, when T never got there, one to discard.
    if (SPLAT_DEPTH) depth[pix] = vec2(t < 1.0 ? wz[j] / (1.0 - t) : 0.0, t > 0.5 ? 0.0 : median[j]);
  }
}

// Two-level voxel ray traversal over the GPU world (the rules of the CPU
// reference engine/render/raycast_cpu.h, in float; layout:
// shared/world_layout.h, params: shared/raycast_params.h).
//
// Coordinates are relative to the reference voxel p.ref (ints) with the ray
// origin `o` in voxel units and a unit world direction `d`; t is in metres.
// Level 1 walks empty cells with the occupancy index (p.occupancy, texel
// buffer `occ_index`, layout in raycast_params.h: a word per 32³ super brick, the
// highest occupied z of every 32 x 32 and 8 x 8 voxel column, and a block of 64
// brick entries per occupied super brick holding the brick record and its 4³
// octant bits). Each is skipped to its exit plane in one step: the box of a
// super-brick or brick column above its highest voxel (to the bounds' top; a
// driving scene's air above the ground), an empty super brick, an empty 8³
// brick, or an empty octant of an occupied brick. A brick costs two loads and a
// column one (none when re-entered: the last ones are kept), no hashing;
// without the index a brick missing from the hash table is skipped. Level 2 is an exact Amanatides–Woo walk over
// every voxel of an occupied brick (the exit-plane times and the voxel kept as
// vectors and updated with selects, no dynamic component indexing; the last
// mask word read is reused while the walk stays in it). Every
// plane time is (integer plane - o) / dd with the same formula on both
// levels, recomputed from integer indices (no accumulated t += tDelta), so the
// cell exit found on level 1 equals the voxel exit level 2 would have found.
// After skipping a cell the next voxel is the exit plane's neighbour on the
// exit axis and, on the other axes, floor(o + t·dd) corrected against the
// same plane formula (raycast_locate), with planes crossed exactly at the exit
// time resolved in the flat walk's x, y, z tie order. Axes with dd == 0 are disabled (time
// RAYCAST_BIG, no division by 0). Ties step x before y before z.
//
// With RAYCAST_EXACT_F64 (shaders/raycast_exact.comp) a camera ray's semantic chord within
// float rounding of eps_sem is recomputed in double (raycast_chord_f64), so the first-hit
// decision is the reference's; the including shader then declares `cam64` (RaycastCameraF64).
//
// The including shader declares world_table / world_bricks (see
// world_lookup.glsl), the texel buffers `usamplerBuffer occ_index` (the occupancy index) and
// `usamplerBuffer brick_words` (world_bricks as R32_UINT texels: texel fetches are gathers on
// lavapipe, where storage-buffer loads at divergent addresses run lane by lane), the push constant block `p` (RaycastParams) and the
// bool RAYCAST_SKIP_EMPTY (false: empty bricks are walked voxel by voxel too,
// the flat walk of the CPU reference, for benchmarks) first.
#ifndef ICUBE_RAYCAST_TRAVERSE_GLSL
#define ICUBE_RAYCAST_TRAVERSE_GLSL

#include "shared/raycast_params.h"

const float RAYCAST_BIG = 3.0e38;

float raycast_plane_t(int plane, float o, float dd) { return (float(plane) - o) / dd; }
int raycast_enter_plane(int v, int st) { return st > 0 ? v : v + 1; }
int raycast_exit_plane(int v, int st) { return st > 0 ? v + 1 : v; }

// The voxel on one axis containing the ray at t; a plane crossed exactly at t
// counts as crossed when `ties_crossed` (see raycast_cpu.cpp locate_axis).
int raycast_locate(float o, float dd, int st, float t, bool ties_crossed) {
  int v = int(floor(o + t * dd));
  const float tn = raycast_plane_t(raycast_exit_plane(v, st), o, dd);
  const float tp = raycast_plane_t(raycast_enter_plane(v, st), o, dd);
  if (tn < t || (ties_crossed && tn == t))
    v += st;
  else if (tp > t || (!ties_crossed && tp == t))
    v -= st;
  return v;
}

int raycast_argmin(vec3 tm) { return tm.x <= tm.y ? (tm.x <= tm.z ? 0 : 2) : (tm.y <= tm.z ? 1 : 2); }

#if RAYCAST_EXACT_F64
// The CPU reference's semantic chord (min(exit, t1) - entry, in double) of relative voxel v
// on the camera ray of pixel pix (cam64: shared/raycast_f64_params.h), for chords within float
// rounding of eps_sem. The entry is the latest entry plane of v or the bounds entry t0, as the
// reference walk's t; `precise` keeps the double operations unfused, as on the CPU.
double raycast_chord_f64(ivec3 v, uvec2 pix, ivec3 lo, ivec3 hi) {
  precise dvec3 dc = dvec3((double(pix.x) + cam64.pixel_offset - cam64.cx) / cam64.fx,
                           (double(pix.y) + cam64.pixel_offset - cam64.cy) / cam64.fy, 1.0LF);
  precise double n2 = dc.x * dc.x + dc.y * dc.y + dc.z * dc.z;
  dc = dc * (1.0LF / sqrt(n2));
  precise dvec3 dw = dvec3(cam64.r00 * dc.x + cam64.r01 * dc.y + cam64.r02 * dc.z,
                           cam64.r10 * dc.x + cam64.r11 * dc.y + cam64.r12 * dc.z,
                           cam64.r20 * dc.x + cam64.r21 * dc.y + cam64.r22 * dc.z);
  n2 = dw.x * dw.x + dw.y * dw.y + dw.z * dw.z;
  dw = dw * (1.0LF / sqrt(n2));
  precise const dvec3 dd = dw / cam64.voxel_size;
  const dvec3 o = dvec3(cam64.off_x, cam64.off_y, cam64.off_z);
  double t0 = 0.0LF, t1 = cam64.t_max, te = 0.0LF, tx = 1.0e300LF;
  for (int a = 0; a < 3; ++a) {
    if (dd[a] == 0.0LF) continue;
    precise const double ta = (double(lo[a]) - o[a]) / dd[a], tb = (double(hi[a]) - o[a]) / dd[a];
    t0 = max(t0, min(ta, tb));
    t1 = min(t1, max(ta, tb));
    const int st = dd[a] > 0.0LF ? 1 : -1;
    precise const double tin = (double(st > 0 ? v[a] : v[a] + 1) - o[a]) / dd[a];
    precise const double tout = (double(st > 0 ? v[a] + 1 : v[a]) - o[a]) / dd[a];
    te = max(te, tin);
    tx = min(tx, tout);
  }
  precise const double chord = min(tx, t1) - max(te, t0);
  return max(chord, 0.0LF);
}
#endif

RaycastHit raycast_traverse(vec3 o, vec3 d, uvec2 pix) {
  RaycastHit h;
  h.t_sem = 0.0; h.t_depth = 0.0; h.sem_class = 0u; h.sem_instance = 0u;
  h.ijk_x = 0; h.ijk_y = 0; h.ijk_z = 0; h.normal = RAYCAST_NORMAL_NONE;
  h.steps = 0u; h.flags = 0u; h.pad1 = 0u; h.pad2 = 0u;

  const ivec3 ref = ivec3(p.ref_x, p.ref_y, p.ref_z);
  const ivec3 lo = ivec3(p.lo_x, p.lo_y, p.lo_z);
  const ivec3 hi = ivec3(p.hi_x, p.hi_y, p.hi_z);
  const vec3 dd = d * p.inv_voxel;
  const ivec3 st = ivec3(sign(dd));

  // Slab clip to the brick bounds.
  float t0 = 0.0, t1 = p.t_max;
  int eaxis = -1;
  for (int a = 0; a < 3; ++a) {
    if (st[a] == 0) {
      if (o[a] < float(lo[a]) || o[a] >= float(hi[a])) return h;
      continue;
    }
    float ta = raycast_plane_t(lo[a], o[a], dd[a]), tb = raycast_plane_t(hi[a], o[a], dd[a]);
    float tn = min(ta, tb), tf = max(ta, tb);
    if (tn >= t0) { t0 = tn; eaxis = a; }  // ties: the last axis in x, y, z order is the entry face
    t1 = min(t1, tf);
  }
  if (!(t0 < t1)) return h;

  ivec3 v;
  for (int a = 0; a < 3; ++a) {
    if (a == eaxis) v[a] = st[a] > 0 ? lo[a] : hi[a] - 1;
    else if (st[a] == 0 || eaxis < 0) v[a] = clamp(int(floor(o[a])), lo[a], hi[a] - 1);  // started inside
    else v[a] = clamp(raycast_locate(o[a], dd[a], st[a], t0, a < eaxis), lo[a], hi[a] - 1);
  }

  float t = t0;
  int normal = eaxis >= 0 ? -(eaxis + 1) * st[eaxis] : RAYCAST_NORMAL_NONE;
  bool sem = false, dep = false, in_run = false, near = false;
  float run_t = 0.0, run_len = 0.0, gap = 0.0;
  uint steps = 0u;
  // Occupancy index (see raycast_params.h): super-brick words over the bounds' box, then blocks.
  const bool occ_on = p.occupancy != 0u && RAYCAST_SKIP_EMPTY;
  const ivec3 smin = (ref + lo) >> RAYCAST_SUPER_SHIFT;
  const ivec3 sdim = ((ref + hi - 1) >> RAYCAST_SUPER_SHIFT) - smin + 1;
  const uint col_word = uint(sdim.x) * uint(sdim.y) * uint(sdim.z) + 1u;
  const uint scol_word = col_word + 16u * uint(sdim.x) * uint(sdim.y);
  const uint block_word = scol_word + uint(sdim.x) * uint(sdim.y);
  const int col_base = 32 * smin.z - 1;  // column height word h: highest occupied z = col_base + h
  // Each outer iteration moves to a new cell (super brick, brick or 4³ octant) or walks one
  // brick's voxels up to an empty octant; bound it by twice the octants a line can cross.
  const ivec3 ext = hi - lo;
  const uint max_outer = uint(ext.x + ext.y + ext.z) / 2u + 16u;
  // The last brick looked up: its coordinate, and its super word (0: empty super brick) and
  // block entry (0: no brick), so re-entering it after an octant skip costs no loads.
  ivec3 last_bc = ivec3(0x7fffffff);
  uint last_super = 0u, last_entry = 0u;
  // The last brick column looked up and its highest occupied z (col_base: none).
  ivec2 last_col = ivec2(0x7fffffff);
  int col_top = 0;
  ivec2 last_scol = ivec2(0x7fffffff);  // the same for the super-brick column
  int scol_top = 0;
  for (uint outer = 0u; outer < max_outer; ++outer) {
    const ivec3 av = ref + v;
    ivec3 bcoord = av >> 3;  // arithmetic shift: floor(ijk / 8)
    uint b = WORLD_EMPTY_SLOT;
    uint octs = 0xffu;  // the brick's occupied 4³ octants
    int shift = 3;  // size of the empty cell to skip: 4 (octant), 8 (brick) or 32 (super brick)
    bool empty;
    bool above = false;  // above every occupied voxel of the brick column: skip the column's rest
    if (occ_on) {
      if (bcoord != last_bc) {
        const ivec3 sc = (av >> RAYCAST_SUPER_SHIFT) - smin;
        last_super = texelFetch(occ_index, sc.x + sdim.x * (sc.y + sdim.y * sc.z)).x;
        last_entry = 0u;
        if (last_super != 0u) {
          const ivec3 lb = bcoord & 3;
          last_entry = texelFetch(occ_index, int(block_word + (last_super - 1u) * RAYCAST_BLOCK_WORDS) + lb.x + 4 * lb.y + 16 * lb.z).x;
        }
        last_bc = bcoord;
      }
      empty = last_entry == 0u;
      const ivec2 scoord = av.xy >> RAYCAST_SUPER_SHIFT;
      if (scoord != last_scol) {
        const ivec2 c = scoord - smin.xy;
        scol_top = col_base + int(texelFetch(occ_index, int(scol_word) + c.x + sdim.x * c.y).x);
        last_scol = scoord;
      }
      if (av.z > scol_top) {  // above the whole 32 x 32 column: the longest skip
        above = true;
        empty = true;
        shift = RAYCAST_SUPER_SHIFT;
      } else if (last_super == 0u) {
        shift = RAYCAST_SUPER_SHIFT;  // empty super brick
      } else {
        {
          if (bcoord.xy != last_col) {
            const ivec2 c = bcoord.xy - 4 * smin.xy;
            col_top = col_base + int(texelFetch(occ_index, int(col_word) + c.x + 4 * sdim.x * c.y).x);
            last_col = bcoord.xy;
          }
          if (av.z > col_top) {  // above the 8 x 8 column
            above = true;
            empty = true;
          } else if (!empty) {
            b = (last_entry >> 8u) - 1u;
            octs = last_entry & 0xffu;
            const ivec3 oc = (av >> 2) & 1;
            if (((octs >> uint(oc.x + 2 * oc.y + 4 * oc.z)) & 1u) == 0u) {
              empty = true;
              shift = 2;
            }
          }
        }
      }
    } else {
      b = world_find_brick(bcoord, p.table_mask);
      empty = b == WORLD_EMPTY_SLOT && RAYCAST_SKIP_EMPTY;
    }
    if (empty) {
      // Skip the empty cell: exit plane on each moving axis, the first one wins.
      ++steps;
      ivec3 clo, chi;
      if (above) {
        // The box of the (super-brick or brick) column above its top: x, y of the column, z from
        // top + 1 (when the current super brick / brick is empty too: from its floor if lower) up
        // to the bounds.
        const bool super_col = shift == RAYCAST_SUPER_SHIFT;
        const int top = super_col ? scol_top : col_top;
        const int floor_z = super_col ? (av.z >> RAYCAST_SUPER_SHIFT) << RAYCAST_SUPER_SHIFT : bcoord.z << 3;
        const bool cell_empty = super_col ? last_super == 0u : last_entry == 0u;
        const int zlo = cell_empty ? min(top + 1, floor_z) : top + 1;
        clo = ivec3(((av.xy >> shift) << shift) - ref.xy, zlo - ref.z);
        chi = ivec3(clo.xy + (1 << shift), hi.z);
      } else {
        clo = ((av >> shift) << shift) - ref;
        chi = clo + ivec3(1 << shift);
      }
      float tb = RAYCAST_BIG;
      int e = 0;
      for (int a = 0; a < 3; ++a) {
        if (st[a] == 0) continue;
        float ta = raycast_plane_t(st[a] > 0 ? chi[a] : clo[a], o[a], dd[a]);
        if (ta < tb) { tb = ta; e = a; }
      }
      if (in_run) {
        gap += max(min(tb, t1) - t, 0.0);
        if (gap > p.gap_eps) in_run = false;
      }
      if (tb >= t1) break;
      t = max(t, tb);
      for (int a = 0; a < 3; ++a) {
        if (a == e) v[a] = st[a] > 0 ? chi[a] : clo[a] - 1;
        else if (st[a] != 0) {
          // Never behind the current voxel: a plane at exactly t that the walk already crossed
          // (e.g. the origin's own plane at t = 0) stays crossed, as in the flat walk.
          const int lv = clamp(raycast_locate(o[a], dd[a], st[a], t, a < e), clo[a], chi[a] - 1);
          v[a] = st[a] > 0 ? max(lv, v[a]) : min(lv, v[a]);
        }
      }
      normal = -(e + 1) * st[e];
      if (v[e] < lo[e] || v[e] >= hi[e]) break;
      continue;
    }

    // Occupied brick (or any brick without skipping): exact voxel walk until the ray leaves the brick.
    const ivec3 blo = (bcoord << 3) - ref;
    const ivec3 bhi = blo + ivec3(8);
    const bool present = b != WORLD_EMPTY_SLOT;
    const uint base = present ? b * WORLD_BRICK_UINTS : 0u;
    // Exit-plane times of the current voxel, updated as whole vectors (no dynamic component
    // indexing, which lavapipe lowers to per-lane memory accesses).
    const bvec3 moving = notEqual(st, ivec3(0));
    const ivec3 up = ivec3(greaterThan(st, ivec3(0)));  // exit plane = v + up
    const vec3 big = vec3(RAYCAST_BIG);
    vec3 tm = mix(big, (vec3(v + up) - o) / dd, moving);
    uint last_wi = 0xffffffffu, last_w = 0u;
    bool done = false;
    for (;;) {
      ++steps;
      const int e = raycast_argmin(tm);
      const float tx = min(tm.x, min(tm.y, tm.z));
      const float chord = max(min(tx, t1) - t, 0.0);
      const ivec3 l = v - blo;
      const uint n = uint(l.x | (l.y << 3) | (l.z << 6));
      bool occupied = false;
      if (present) {
        const uint wi = base + WORLD_MASK_OFFSET + (n >> 5u);
        if (wi != last_wi) { last_wi = wi; last_w = texelFetch(brick_words, int(wi)).x; }
        occupied = ((last_w >> (n & 31u)) & 1u) != 0u;
      }
      if (occupied) {
        bool sem_pass = chord >= p.eps_sem;
        // Within float rounding of the threshold (|error| << 1e-6 + 1e-6 t m): the exact variant
        // decides in double; the float one flags the ray for it when asked (p.mark_near).
        if (!sem && p.width != 0u && abs(chord - p.eps_sem) <= 1.0e-6 + 1.0e-6 * t) {
#if RAYCAST_EXACT_F64
          sem_pass = raycast_chord_f64(v, pix, lo, hi) >= cam64.eps_sem;
#else
          near = near || p.mark_near != 0u;
#endif
        }
        if (!sem && sem_pass) {
          sem = true;
          h.t_sem = t;
          h.sem_class = (texelFetch(brick_words, int(base + WORLD_CLASS_OFFSET + (n >> 2u))).x >> ((n & 3u) * 8u)) & 0xffu;
          h.sem_instance = (texelFetch(brick_words, int(base + WORLD_INSTANCE_OFFSET + (n >> 1u))).x >> ((n & 1u) * 16u)) & 0xffffu;
          h.ijk_x = ref.x + v.x; h.ijk_y = ref.y + v.y; h.ijk_z = ref.z + v.z;
          h.normal = normal;
        }
        if (!dep) {
          if (!in_run) { in_run = true; run_t = t; run_len = 0.0; }
          run_len += chord;
          gap = 0.0;
          if (run_len >= p.eps_depth) { dep = true; h.t_depth = run_t; }
        }
        if (sem && dep) { done = true; break; }
      } else if (in_run) {
        gap += chord;
        if (gap > p.gap_eps) in_run = false;
      }
      if (tx >= t1) { done = true; break; }
      t = max(t, tx);
      const bvec3 em = equal(ivec3(e), ivec3(0, 1, 2));
      const ivec3 se = ivec3(em) * st;
      v += se;
      normal = -(e + 1) * (se.x + se.y + se.z);
      tm = mix(tm, (vec3(v + up) - o) / dd, em);
      if (any(lessThan(v, blo)) || any(greaterThanEqual(v, bhi))) break;
      if (octs != 0xffu) {
        // In another octant of the brick: leave the walk when it is empty (skipped above).
        const ivec3 oc = ((ref + v) >> 2) & 1;
        if (((octs >> uint(oc.x + 2 * oc.y + 4 * oc.z)) & 1u) == 0u) break;
      }
    }
    if (done || v[0] < lo[0] || v[0] >= hi[0] || v[1] < lo[1] || v[1] >= hi[1] || v[2] < lo[2] || v[2] >= hi[2]) break;
  }
  h.steps = steps;
  h.flags = (sem ? RAYCAST_FLAG_SEM : 0u) | (dep ? RAYCAST_FLAG_DEPTH : 0u) | (near ? RAYCAST_FLAG_NEAR : 0u);
  return h;
}

#endif

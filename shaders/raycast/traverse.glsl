// Voxel ray traversal over the GPU world (the rules of the CPU reference
// engine/render/raycast_cpu.h, in float; layout: shared/world_layout.h, params:
// shared/raycast_params.h).
//
// Coordinates are relative to the reference voxel p.ref (ints) with the ray
// origin `o` in voxel units and a unit world direction `d`; t is in metres.
// One loop, one cell per iteration: the cell containing the current voxel is
// looked up in the occupancy index (RAYCAST_OCCUPANCY, texel buffer `occ_index`,
// layout in raycast_params.h: a (block, 32 x 32 column height) pair per 32³
// super brick, then per brick of an occupied super brick a (record + octants,
// 8 x 8 column height) pair, then the voxel's word of the record's mask copy
// in the index (`occ_masks`): three dependent fetches, no hashing) and is
// either skipped to its exit plane in one step —
// the box of a super-brick or brick column above its highest voxel (to the
// bounds' top: a driving scene's air above the ground), an empty super brick,
// an empty 8³ brick, an empty 4³ octant of an occupied brick — or, inside an
// occupied octant, is the voxel itself (an exact Amanatides–Woo step). Without
// the index (RAYCAST_OCCUPANCY false) a brick missing from the hash table is
// the skipped cell. Why one loop: lavapipe executes every instruction of a
// loop body for all lanes (divergent ifs are masked, not branched) and a
// texel fetch is a call that spills every live register, so a nested
// skip-loop / voxel-loop pair paid for both bodies and all their fetches on
// every step; here each step costs one body with three fetches. On GPUs the
// single loop also keeps a subgroup's lanes in the same code.
// Every plane time is (integer plane - o) / dd, one formula for every cell
// size, recomputed from integer indices (no accumulated t += tDelta), so a
// skipped cell's exit equals the exit the voxel walk would have found. After
// skipping a cell the next voxel is the exit plane's neighbour on the exit
// axis and, on the other axes, floor(o + t·dd) corrected against the same
// plane formula (raycast_locate), with planes crossed exactly at the exit
// time resolved in the flat walk's x, y, z tie order; a voxel step keeps the
// other axes. Axes with dd == 0 are disabled (time RAYCAST_BIG, no division
// by 0). Ties step x before y before z. A hit's class and instance are read
// after the loop.
//
// With RAYCAST_EXACT_F64 (shaders/raycast/exact.comp) a camera ray's semantic chord within
// float rounding of eps_sem is recomputed in double (raycast_chord_f64), so the first-hit
// decision is the reference's; the including shader then declares `cam64` (RaycastCameraF64).
// With RAYCAST_EXACT_DF (shaders/raycast/exact_df.comp, devices without shaderFloat64) the
// same chord is computed in double-float (raycast/chord_df.glsl, common/df.glsl) from `camdf`
// (RaycastCameraDf); see there why its decisions are the reference's.
//
// The including shader declares the texel buffers `world_table_texels` (the hash table as
// R32G32B32A32_UINT), `usamplerBuffer brick_words` (the brick records as R32_UINT, also named
// `world_brick_texels` for world/lookup_texel.glsl), `occ_index` and `occ_masks` (the occupancy
// index as R32G32_UINT and R32_UINT texels; texel fetches are gathers on lavapipe, where
// storage-buffer loads at divergent addresses run lane by lane), the push constant
// block `p` (RaycastParams) and the bools RAYCAST_OCCUPANCY (see above) and RAYCAST_SKIP_EMPTY
// (false: empty bricks are walked voxel by voxel too, the flat walk of the CPU reference, for
// benchmarks) first.
#ifndef ICUBE_RAYCAST_TRAVERSE_GLSL
#define ICUBE_RAYCAST_TRAVERSE_GLSL

#include "shared/raycast_params.h"

const float RAYCAST_BIG = 3.0e38;

// The time of a voxel plane, correctly rounded: Vulkan lets a driver divide as a · rcp(b)
// (2.5 ulp; NVIDIA's does), which breaks the exact ties of planes crossed at one time (a ray
// through a voxel edge) that the CPU reference and IEEE-dividing drivers (lavapipe) resolve in
// x, y, z order. One residual step, r = a − q·b exact in an FMA, rounds the quotient as IEEE
// division does; on a correctly rounding driver it returns q unchanged. Infinite quotients
// (a grazing ray's far planes) pass through, as the residual would be NaN.
float raycast_plane_t(int plane, float o, float dd) {
  precise const float a = float(plane) - o;
  precise const float q = a / dd;
  if (isinf(q)) return q;
  precise const float r = fma(-q, dd, a);
  return fma(r, 1.0 / dd, q);
}
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

// RAYCAST_MARK_TIES: how close (voxel units) the ray's point may come to a voxel plane, or a
// threshold decision to its threshold (metres, x voxel size), before float rounding could decide it
// otherwise than a double walk of the same ray: 4e-7 (~7 float ulps) of the largest coordinate
// magnitude involved, |o| + t / voxel size, plus 2 voxels.
float raycast_tie_eps(vec3 o, float t) { return 4.0e-7 * (2.0 + max(abs(o.x), max(abs(o.y), abs(o.z))) + t * p.inv_voxel); }
// Whether the ray's point on one axis at time t lies within eps voxels of a voxel plane.
bool raycast_near_plane(float o, float dd, float t, float eps) {
  const float x = o + t * dd;
  return abs(x - round(x)) <= eps;
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
#elif RAYCAST_EXACT_DF
#include "raycast/chord_df.glsl"
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

  bool near = false;
  if (RAYCAST_MARK_TIES) {
    // The start point (the origin or the bounds entry point) within rounding of voxel planes of other
    // axes: a double walk may start on a plane's other side. Moving off the planes, such walks differ
    // only by visits of (nearly) zero length to the voxels around the point, the 2^k of them beside
    // its k near planes, so the ray is marked only when one of those is occupied; and always when it
    // does not move along a near plane's axis (it stays on the plane).
    const float eps = raycast_tie_eps(o, t0);
    uint near_mask = 0u;
    ivec3 plane = ivec3(0);
    for (int a = 0; a < 3; ++a) {
      const float x = o[a] + t0 * dd[a];
      if (a != eaxis && abs(x - round(x)) <= eps) {
        near_mask |= 1u << uint(a);
        plane[a] = int(round(x));
        if (st[a] == 0) near = true;
      }
    }
    for (uint c = 0u; c < 8u && near_mask != 0u && !near; ++c) {
      if ((c & ~near_mask) != 0u) continue;  // one corner per subset of the near axes
      ivec3 w = v;
      for (int a = 0; a < 3; ++a)
        if ((near_mask & (1u << uint(a))) != 0u) w[a] = plane[a] - 1 + int((c >> uint(a)) & 1u);
      near = world_occupied_texel(ref + w, p.table_mask);
    }
  }

  float t = t0;
  int normal = eaxis >= 0 ? -(eaxis + 1) * st[eaxis] : RAYCAST_NORMAL_NONE;
  bool sem = false, dep = false, in_run = false;
  float run_t = 0.0, run_len = 0.0, gap = 0.0;
  uint sem_base = 0u, sem_n = 0u;  // the semantic hit's brick record base and voxel index
  uint steps = 0u;
  // Occupancy index (see raycast_params.h): super pairs over the bounds' box, then blocks.
  const bool occ_on = RAYCAST_OCCUPANCY && RAYCAST_SKIP_EMPTY;  // the host sets p.occupancy to match
  const ivec3 smin = (ref + lo) >> RAYCAST_SUPER_SHIFT;
  const ivec3 sdim = ((ref + hi - 1) >> RAYCAST_SUPER_SHIFT) - smin + 1;
  const int block_pair = sdim.x * sdim.y * sdim.z + 1;  // pair index of block 0's first entry
  const int col_base = 32 * smin.z - 1;  // height word h: highest occupied z = col_base + h
  const int mask_word = occ_on ? int(texelFetch(occ_index, block_pair - 1).y) : 0;  // word 2 supers + 1
  // One cell per iteration: an empty cell skipped to its exit plane or one voxel of an occupied
  // octant. Each crosses at least one voxel plane, so a line through the bounds needs at most
  // ext.x + ext.y + ext.z of them.
  const ivec3 ext = hi - lo;
  const uint max_steps = uint(ext.x + ext.y + ext.z) + 4u;
  for (uint it = 0u; it < max_steps; ++it) {
    ++steps;
    const ivec3 av = ref + v;
    const ivec3 l = av & 7;
    const uint n = uint(l.x | (l.y << 3) | (l.z << 6));  // voxel index in its brick
    int shift = 0;       // the cell: 2^shift voxels a side (0: the voxel itself)
    bool above = false;  // the box of a column above its top (to the bounds' top) instead
    bool cell_empty = false;  // with `above`: the super brick / brick itself is empty too
    int top = 0;              // with `above`: the column's highest occupied z
    bool occupied = false;    // shift 0: the voxel is occupied
    uint base = 0u;           // brick record base (words) when the voxel's brick has one
    if (occ_on) {
      const ivec3 sc = (av >> RAYCAST_SUPER_SHIFT) - smin;
      const uvec2 sup = texelFetch(occ_index, sc.x + sdim.x * (sc.y + sdim.y * sc.z)).xy;
      const ivec3 lb = (av >> 3) & 3;
      const uvec2 ent = texelFetch(occ_index, sup.x != 0u ? block_pair + int(sup.x - 1u) * 64 + lb.x + 4 * lb.y + 16 * lb.z : 0).xy;
      const uint entry = sup.x != 0u ? ent.x : 0u;
      const uint record = entry != 0u ? (entry >> 8u) - 1u : 0u;
      base = record * WORLD_BRICK_UINTS;
      const uint word = texelFetch(occ_masks, entry != 0u ? mask_word + int(record * RAYCAST_MASK_WORDS + (n >> 5u)) : 0).x;
      const int scol_top = col_base + int(sup.y), col_top = col_base + int(ent.y);
      const ivec3 oc = (av >> 2) & 1;
      if (av.z > scol_top) {  // above the whole 32 x 32 column: the longest skip
        above = true;
        shift = RAYCAST_SUPER_SHIFT;
        top = scol_top;
        cell_empty = sup.x == 0u;
      } else if (sup.x == 0u) {
        shift = RAYCAST_SUPER_SHIFT;  // empty super brick
      } else if (av.z > col_top) {  // above the 8 x 8 column
        above = true;
        shift = 3;
        top = col_top;
        cell_empty = entry == 0u;
      } else if (entry == 0u) {
        shift = 3;  // empty brick
      } else if (((entry >> uint(oc.x + 2 * oc.y + 4 * oc.z)) & 1u) == 0u) {
        shift = 2;  // empty octant of an occupied brick
      } else {
        occupied = ((word >> (n & 31u)) & 1u) != 0u;
      }
    } else {
      const uint b = world_find_brick_texel(av >> 3, p.table_mask);
      if (b == WORLD_EMPTY_SLOT) {
        shift = RAYCAST_SKIP_EMPTY ? 3 : 0;  // without skipping: an empty voxel
      } else {
        base = b * WORLD_BRICK_UINTS;
        occupied = ((texelFetch(brick_words, int(base + WORLD_MASK_OFFSET + (n >> 5u))).x >> (n & 31u)) & 1u) != 0u;
      }
    }
    // The cell's box [clo, chi) relative to ref.
    ivec3 clo, chi;
    if (above) {
      // x, y of the column, z from top + 1 (when the current super brick / brick is empty too:
      // from its floor if lower) up to the bounds.
      const int floor_z = (av.z >> shift) << shift;
      const int zlo = cell_empty ? min(top + 1, floor_z) : top + 1;
      clo = ivec3(((av.xy >> shift) << shift) - ref.xy, zlo - ref.z);
      chi = ivec3(clo.xy + (1 << shift), hi.z);
    } else {
      clo = ((av >> shift) << shift) - ref;
      chi = clo + ivec3(1 << shift);
    }
    // Exit plane on each moving axis; the first wins, ties in x, y, z order.
    float tb = RAYCAST_BIG;
    int e = 0;
    for (int a = 0; a < 3; ++a) {
      if (st[a] == 0) continue;
      const float ta = raycast_plane_t(st[a] > 0 ? chi[a] : clo[a], o[a], dd[a]);
      if (ta < tb) { tb = ta; e = a; }
    }
    const float chord = max(min(tb, t1) - t, 0.0);
    if (occupied) {
      bool sem_pass = chord >= p.eps_sem;
      // Within float rounding of the threshold (|error| << 1e-6 + 1e-6 t m): the exact variant
      // decides in double; the float one flags the ray for it when asked (p.mark_near).
      if (!sem && (p.width != 0u || RAYCAST_MARK_TIES) && abs(chord - p.eps_sem) <= 1.0e-6 + 1.0e-6 * t) {
#if RAYCAST_EXACT_F64
        sem_pass = raycast_chord_f64(v, pix, lo, hi) >= cam64.eps_sem;
#elif RAYCAST_EXACT_DF
        sem_pass = !df_less(raycast_chord_df(camdf, v, pix, lo, hi), camdf.eps_sem);
#else
        near = near || p.mark_near != 0u;
#endif
      }
      if (!sem && sem_pass) {
        sem = true;
        h.t_sem = t;
        sem_base = base;  // class and instance are read after the walk
        sem_n = n;
        h.ijk_x = av.x; h.ijk_y = av.y; h.ijk_z = av.z;
        h.normal = normal;
      }
      if (!dep) {
        if (!in_run) { in_run = true; run_t = t; run_len = 0.0; }
        run_len += chord;
        gap = 0.0;
        if (run_len >= p.eps_depth) {
          dep = true;
          h.t_depth = run_t;
          if (RAYCAST_MARK_TIES && run_len - p.eps_depth <= raycast_tie_eps(o, tb) * 8.0 / p.inv_voxel) near = true;
        }
      }
      if (sem && dep) break;
    } else if (in_run) {
      gap += chord;
      if (gap > p.gap_eps) {
        in_run = false;
        if (RAYCAST_MARK_TIES && p.eps_depth - run_len <= raycast_tie_eps(o, t) * 8.0 / p.inv_voxel) near = true;
      }
    }
    if (tb >= t1) break;
    if (RAYCAST_MARK_TIES) {
      // The next cell: another axis's plane crossed within rounding of the exit (voxel steps), or the
      // point the next voxel is located from near a plane (after a skipped cell).
      const float eps = raycast_tie_eps(o, tb);
      for (int a = 0; a < 3; ++a)
        if (a != e && st[a] != 0 && raycast_near_plane(o[a], dd[a], tb, eps)) near = true;
    }
    t = max(t, tb);
    // Next voxel: the exit plane's neighbour on the exit axis; on the others (a skipped cell)
    // the voxel containing the ray at t, never behind the current one (a plane at exactly t
    // that the walk already crossed, e.g. the origin's own plane at t = 0, stays crossed, as
    // in the flat walk). Within a voxel step the other axes keep their voxel.
    const int ste = e == 0 ? st.x : (e == 1 ? st.y : st.z);
    for (int a = 0; a < 3; ++a) {
      if (a == e) v[a] = st[a] > 0 ? chi[a] : clo[a] - 1;
      else if (st[a] != 0 && shift != 0) {
        const int lv = clamp(raycast_locate(o[a], dd[a], st[a], t, a < e), clo[a], chi[a] - 1);
        v[a] = st[a] > 0 ? max(lv, v[a]) : min(lv, v[a]);
      }
    }
    normal = -(e + 1) * ste;
    if (any(lessThan(v, lo)) || any(greaterThanEqual(v, hi))) break;
  }
  // A run still open where the walk ended (the bounds or t_max) short of eps_depth by a rounding.
  if (RAYCAST_MARK_TIES && in_run && !dep && p.eps_depth - run_len <= raycast_tie_eps(o, t1) * 8.0 / p.inv_voxel)
    near = true;
  if (sem) {
    // Texel fetches are function calls on lavapipe that every iteration of a loop would execute
    // (masked), so the hit's attributes are read once here.
    h.sem_class = (texelFetch(brick_words, int(sem_base + WORLD_CLASS_OFFSET + (sem_n >> 2u))).x >> ((sem_n & 3u) * 8u)) & 0xffu;
    h.sem_instance =
        (texelFetch(brick_words, int(sem_base + WORLD_INSTANCE_OFFSET + (sem_n >> 1u))).x >> ((sem_n & 1u) * 16u)) & 0xffffu;
  }
  h.steps = steps;
  h.flags = (sem ? RAYCAST_FLAG_SEM : 0u) | (dep ? RAYCAST_FLAG_DEPTH : 0u) | (near ? RAYCAST_FLAG_NEAR : 0u);
  return h;
}

#endif

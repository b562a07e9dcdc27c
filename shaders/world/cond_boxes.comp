#version 460
#extension GL_GOOGLE_include_directive : require
// cond_boxes: per latent voxel of the Stage-1 condition volume (conventions
// §7), the position channels i, j, k (raw ijk in [-32, 31]) and the box
// channels sin θ, cos θ. The voxel is the cell [ijk·vs, (ijk+1)·vs],
// vs = (0.8, 0.8, 0.4), in the chunk frame. For every box (a lane-uniform
// loop) whose bounds overlap the cell: exact volume of box ∩ cell by clipping
// each face of one solid against the other's 6 planes (Sutherland–Hodgman,
// ≤ 10 vertices, fixed-size arrays) and summing 1/3 A·x over the 12 clipped
// faces (divergence theorem, coordinates relative to the cell centre). A box
// face coplanar and co-oriented with a cell face is counted once, on the cell
// face, which is not clipped by that plane; coplanar opposite faces: 0.
// Fast paths before clipping: a separating box axis gives 0, a cell inside the
// box gives the cell volume (both exact up to rounding of the tests). IoU = I / (Vbox + Vcell - I); the first max-IoU box wins; if
// its I > min_intersection, write its (sin θ, cos θ), else 0. All in float.
// Host module: engine/world/conditions_gpu.{h,cpp}; CPU reference (double):
// engine/world/box_overlap.cpp, conditions.cpp; test: tests/world/test_conditions.cpp.
#include "shared/conditions_params.h"
#include "common/dispatch.glsl"

layout(local_size_x_id = 0) in;
layout(push_constant) uniform Push { CondBoxesParams p; };
layout(std430, binding = 0) readonly buffer Boxes { vec4 boxes[]; };
layout(std430, binding = 1) writeonly buffer Volume { float vol[]; };

const int kMaxVerts = 10;
const uint kVox = COND_DIM * COND_DIM * COND_DIM;

// Clips the quad q0..q3 (counter-clockwise seen from outside) to the solid
// {x : |dot(axes[k], x - center)| <= half_ext[k]}, except by plane `skip`
// (index 2k + (0: +axes[k], 1: -axes[k]); -1 = none), and returns 1/3 A · x0.
float clipped_face_term(vec3 q0, vec3 q1, vec3 q2, vec3 q3, mat3 axes, vec3 center, vec3 half_ext, int skip) {
  vec3 poly[kMaxVerts];
  vec3 tmp[kMaxVerts];
  poly[0] = q0; poly[1] = q1; poly[2] = q2; poly[3] = q3;
  int n = 4;
  for (int pl = 0; pl < 6; ++pl) {
    if (pl == skip) continue;
    int k = pl >> 1;
    vec3 nrm = (pl & 1) == 0 ? axes[k] : -axes[k];
    float d = dot(nrm, center) + half_ext[k];
    int m = 0;
    for (int i = 0; i < n; ++i) {
      vec3 a = poly[i];
      vec3 b = poly[i + 1 == n ? 0 : i + 1];
      float da = dot(nrm, a) - d, db = dot(nrm, b) - d;
      if (da <= 0.0 && m < kMaxVerts) tmp[m++] = a;
      if (((da < 0.0 && db > 0.0) || (da > 0.0 && db < 0.0)) && m < kMaxVerts) tmp[m++] = a + (b - a) * (da / (da - db));
    }
    n = m;
    if (n < 3) return 0.0;
    for (int i = 0; i < n; ++i) poly[i] = tmp[i];
  }
  vec3 area = vec3(0.0);
  for (int i = 1; i + 1 < n; ++i) area += cross(poly[i] - poly[0], poly[i + 1] - poly[0]);
  return dot(area * 0.5, poly[0]) / 3.0;
}

// Face 2k + s of the solid (c, u, h), clipped to the solid (oc, ou, oh) except by plane `skip`.
float face_term(int face, vec3 c, mat3 u, vec3 h, vec3 oc, mat3 ou, vec3 oh, int skip) {
  int k = face >> 1;
  vec3 a = u[(k + 1) % 3] * h[(k + 1) % 3];
  vec3 b = u[(k + 2) % 3] * h[(k + 2) % 3];
  if ((face & 1) == 0) {
    vec3 fc = c + u[k] * h[k];
    return clipped_face_term(fc - a - b, fc + a - b, fc + a + b, fc - a + b, ou, oc, oh, skip);
  }
  vec3 fc = c - u[k] * h[k];
  return clipped_face_term(fc - a - b, fc - a + b, fc + a + b, fc + a - b, ou, oc, oh, skip);
}

// Exact volume of the box (c, u, h) ∩ the cell [-ch, ch] (box_overlap.cpp in float).
float intersection_volume(vec3 c, mat3 u, vec3 h, vec3 ch) {
  const mat3 eye = mat3(1.0);
  // Fast paths (the clipping is slow where private arrays are, as on lavapipe):
  // separated along a box axis -> 0; all cell corners inside the box -> cell volume.
  bool all_inside = true;
  for (int k = 0; k < 3; ++k) {
    float dist = abs(dot(u[k], c));
    float r = dot(abs(u[k]), ch);
    if (dist >= h[k] + r) return 0.0;
    all_inside = all_inside && dist + r <= h[k];
  }
  if (all_inside) return 8.0 * ch.x * ch.y * ch.z;
  // Coplanar face pairs: co-oriented -> counted once on the cell face, which
  // skips its twin plane; opposite -> the solids only touch.
  int cell_twin[6] = int[6](-1, -1, -1, -1, -1, -1);
  uint box_twin = 0u;
  for (int i = 0; i < 6; ++i) {
    int k = i >> 1;
    vec3 nrm = (i & 1) == 0 ? u[k] : -u[k];
    float dn = dot(nrm, c) + h[k];
    for (int j = 0; j < 3; ++j) {
      if (abs(nrm[j]) <= 1.0 - p.coplanar_cos) continue;
      if (abs(dn - ch[j]) <= p.coplanar_dist) {
        box_twin |= 1u << i;
        cell_twin[2 * j + (nrm[j] > 0.0 ? 0 : 1)] = i;
      }
      if (abs(dn + ch[j]) <= p.coplanar_dist) return 0.0;
    }
  }
  float v = 0.0;
  for (int f = 0; f < 6; ++f) v += face_term(f, vec3(0.0), eye, ch, c, u, h, cell_twin[f]);
  for (int f = 0; f < 6; ++f)
    if ((box_twin & (1u << f)) == 0u) v += face_term(f, c, u, h, vec3(0.0), eye, ch, -1);
  return max(v, 0.0);
}

void main() {
  uint vox = ICUBE_THREAD_LINEAR();
  if (vox >= kVox) return;
  uvec3 g = uvec3(vox / (COND_DIM * COND_DIM), (vox / COND_DIM) % COND_DIM, vox % COND_DIM);
  vec3 ijk = vec3(ivec3(g) - ivec3(COND_DIM / 2));
  const vec3 vs = vec3(0.8, 0.8, 0.4);
  vec3 lo = ijk * vs, hi = (ijk + 1.0) * vs;
  vec3 vc = (ijk + 0.5) * vs;
  vec3 ch = vs * 0.5;
  float cell_volume = vs.x * vs.y * vs.z;

  float best_iou = 0.0, best_inter = 0.0, best_sin = 0.0, best_cos = 0.0;
  for (uint b = 0; b < p.num_boxes; ++b) {
    uint o = b * COND_BOX_VEC4S;
    vec4 blo = boxes[o + 5], bhi = boxes[o + 6];
    if (!(all(lessThan(blo.xyz, hi)) && all(lessThan(lo, bhi.xyz)))) continue;
    vec4 c4 = boxes[o];
    vec3 c = c4.xyz - vc;
    vec3 h = boxes[o + 1].xyz;
    mat3 u = mat3(boxes[o + 2].xyz, boxes[o + 3].xyz, boxes[o + 4].xyz);
    float inter = intersection_volume(c, u, h, ch);
    float uni = c4.w + cell_volume - inter;
    float iou = uni > 0.0 ? inter / uni : 0.0;
    if (iou > best_iou) {
      best_iou = iou;
      best_inter = inter;
      best_sin = blo.w;
      best_cos = bhi.w;
    }
  }
  bool on = best_inter > p.min_intersection;
  vol[0 * kVox + vox] = ijk.x;
  vol[1 * kVox + vox] = ijk.y;
  vol[2 * kVox + vox] = ijk.z;
  vol[6 * kVox + vox] = on ? best_sin : 0.0;
  vol[7 * kVox + vox] = on ? best_cos : 0.0;
}

// Push constants and record layout of the Stage-1 condition kernels
// (shaders/world/cond_points.comp, shaders/world/cond_boxes.comp; host module
// engine/world/conditions_gpu.{h,cpp}). Volume layout: float [8][64][64][64]
// (channel, i, j, k), channel order as engine/world/conditions.h.
#ifndef ICUBE_CONDITIONS_PARAMS_H
#define ICUBE_CONDITIONS_PARAMS_H
#include "gpu_types.h"

// One box is COND_BOX_VEC4S vec4s in the box buffer (chunk frame, float):
//   [0] centre.xyz, volume   [1] half extents.xyz, 0
//   [2..4] unit axes x, y, z (.w = 0)
//   [5] bounds lo.xyz, sin θ  [6] bounds hi.xyz, cos θ
#define COND_BOX_VEC4S 7
#define COND_DIM 64

ICUBE_SHADER_NAMESPACE_BEGIN

// cond_points: out[channel][roundEven(q)] = 1 for each grid point q (3 floats) in [0, 64)³,
// points [first, first + n) of the point buffer.
struct CondPointsParams {
  uint n;        // points
  uint channel;  // 3 road_edge, 4 road_line, 5 road_surface
  uint first;    // index of this run's first point in the point buffer
  uint pad0;
};

// cond_boxes: one invocation per latent voxel (64³); writes channels i, j, k, sin θ, cos θ.
struct CondBoxesParams {
  uint num_boxes;
  float min_intersection;  // 0.5 · cell volume: write sin/cos only above this
  float coplanar_cos;      // a box face lies on a cell face plane when cos > 1 - coplanar_cos
  float coplanar_dist;     // ... and the plane offsets differ by <= coplanar_dist metres
};

ICUBE_SHADER_NAMESPACE_END

ICUBE_CHECK_SIZE(CondPointsParams, 16);
ICUBE_CHECK_LAYOUT(CondPointsParams, channel, 4);
ICUBE_CHECK_LAYOUT(CondPointsParams, first, 8);
ICUBE_CHECK_SIZE(CondBoxesParams, 16);
ICUBE_CHECK_LAYOUT(CondBoxesParams, min_intersection, 4);
ICUBE_CHECK_LAYOUT(CondBoxesParams, coplanar_cos, 8);
ICUBE_CHECK_LAYOUT(CondBoxesParams, coplanar_dist, 12);

#endif

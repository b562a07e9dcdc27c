// The body of gsm_project_features (float32) and gsm_project_features_f64
// (GSM_PROJECT_F64: the projection in double, needs shaderFloat64): the GSM
// voxel branch's image features at the 0.1 m children of the first-hit voxels
// — each child's centre projected into every view, the effective-masked
// feature map sampled as F.grid_sample does (bilinear, zeros outside,
// align_corners=False: pixel x = u * width - 0.5), times "this view saw the
// parent first" (a view that did not gives 0, it is not skipped), maxed over
// the views from -inf (or from 0: NN_GSM_PROJECT_FLAG_MAX_FROM_ZERO, the
// official loop of 30 views and more; or from y: NN_GSM_PROJECT_FLAG_ACCUMULATE,
// a window of later views). One invocation per output element y[c][r] of the
// dispatch's window (views, channels and children: the host windows tensors
// past one storage binding; every binding starts at its window, the *_offset
// push constants); the sample point's position is the only part in double
// (the bilinear sum is float32). Layouts in shared/nn_gsm_params.h.
// Host module: kernels/nn/gsm_project_features.{h,cpp}; CPU reference:
// nn::cpu::gsm_project_features. Tests: tests/nn/test_gsm_project_features.cpp.
#include "shared/nn_gsm_params.h"
#include "common/dispatch.glsl"

#ifdef GSM_PROJECT_F64
#define real float64_t
#define real3 f64vec3
#define REAL_PAIR(hi, lo) (float64_t(hi) + float64_t(lo))
#else
#define real float
#define real3 vec3
#define REAL_PAIR(hi, lo) (hi)
#endif

layout(local_size_x = NN_GSM_PROJECT_GROUP) in;
layout(push_constant) uniform Push { GsmProjectParams p; };
layout(std430, binding = 0) readonly buffer Features { float feat[]; };
layout(std430, binding = 1) readonly buffer Mask { float mask[]; };
layout(std430, binding = 2) readonly buffer Coords { int ijk[]; };
layout(std430, binding = 3) readonly buffer Parent { int parent[]; };
layout(std430, binding = 4) readonly buffer Seen { uint seen[]; };   // [parents][views]
layout(std430, binding = 5) readonly buffer Proj { float proj[]; };  // [views][12] (hi, lo) pairs, row-major 3x4
layout(std430, binding = 6) buffer Out { float y_out[]; };

real proj_entry(uint n, uint k) { return REAL_PAIR(proj[(12u * n + k) * 2u], proj[(12u * n + k) * 2u + 1u]); }

// The bilinear sample of channel c of the window's view n's masked features at pixel position (x, y).
float sample_view(uint n, uint c, real x, real y) {
  // Taps exist only for -1 < x < width and -1 < y < height (NaN and infinities fail too).
  if (!(x > real(-1.0) && x < real(p.width) && y > real(-1.0) && y < real(p.height))) return 0.0;
  const real x0 = floor(x), y0 = floor(y);
  const float fx = float(x - x0), fy = float(y - y0);
  const int ix = int(x0), iy = int(y0);
  const uint plane = p.height * p.width;
  float acc = 0.0;
  for (int dy = 0; dy < 2; ++dy)
    for (int dx = 0; dx < 2; ++dx) {
      const int col = ix + dx, row = iy + dy;
      if (col < 0 || row < 0 || col >= int(p.width) || row >= int(p.height)) continue;
      const uint pix = uint(row) * p.width + uint(col);
      if (!(mask[p.mask_offset + n * plane + pix] > 0.0)) continue;
      const float weight = (dx == 1 ? fx : 1.0 - fx) * (dy == 1 ? fy : 1.0 - fy);
      acc = fma(weight, feat[p.features_offset + (n * p.channel_stride + c) * plane + pix], acc);
    }
  return acc;
}

void main() {
  const uint id = ICUBE_THREAD_LINEAR();
  if (id >= p.rows * p.channels) return;
  const uint c = id / p.rows, r = id % p.rows;
  real3 centre;
  for (uint a = 0u; a < 3u; ++a)
    centre[a] = real(ijk[p.ijk_offset + 3u * r + a]) * REAL_PAIR(p.voxel_size_hi[a], p.voxel_size_lo[a]) +
                REAL_PAIR(p.origin_hi[a], p.origin_lo[a]);
  const uint par = uint(parent[p.parent_offset + r]);
  const uint at = p.out_offset + c * p.row_stride + r;
  float best = (p.flags & NN_GSM_PROJECT_FLAG_ACCUMULATE) != 0u        ? y_out[at]
               : (p.flags & NN_GSM_PROJECT_FLAG_MAX_FROM_ZERO) != 0u ? 0.0
                                                                      : -1.0 / 0.0;
  for (uint k = 0u; k < p.view_count; ++k) {
    const uint n = p.view_first + k;
    float v = 0.0;
    if (seen[par * p.views + n] != 0u) {
      real row[3];
      for (uint s = 0u; s < 3u; ++s)
        row[s] = proj_entry(n, 4u * s) * centre.x + proj_entry(n, 4u * s + 1u) * centre.y + proj_entry(n, 4u * s + 2u) * centre.z +
                 proj_entry(n, 4u * s + 3u);
      v = sample_view(k, c, row[0] / row[2] * real(p.width) - real(0.5), row[1] / row[2] * real(p.height) - real(0.5));
    }
    best = max(best, v);
  }
  y_out[at] = best;
}

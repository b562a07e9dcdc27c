// Push constants of shaders/view_shade.comp, the viewer's shading pass
// (host: viewer/view_renderer.{h,cpp}). Shared by GLSL and C++.
#ifndef ICUBE_VIEW_PARAMS_H
#define ICUBE_VIEW_PARAMS_H
#include "gpu_types.h"

#define VIEW_MODE_SHADED 0u
#define VIEW_MODE_SEMANTIC 1u
#define VIEW_MODE_DEPTH 2u
#define VIEW_MODE_INSTANCE 3u
#define VIEW_MODE_COORDS 4u

ICUBE_SHADER_NAMESPACE_BEGIN

struct ViewShadeParams {
  uint width, height;   // render resolution
  uint mode;            // VIEW_MODE_*
  float pixel_offset;   // as RaycastParams
  float sun_x, sun_y, sun_z;  // unit vector towards the sun, world
  float fog_density;          // per metre (exp2 fog)
  float fx, fy, cx, cy;       // intrinsics of the render resolution (z-depth = t · d_cam.z)
  float depth_max;            // metres at the end of the depth ramp
  float ambient;              // shaded: ambient term
  float pad0, pad1;
  // d = normalize(M · (u + o, v + o, 1)), M = R_c2w · K^-1, row-major (for the sky)
  float m00, m01, m02, m10, m11, m12, m20, m21, m22;
  float pad2, pad3, pad4;
};

ICUBE_SHADER_NAMESPACE_END

ICUBE_CHECK_SIZE(ViewShadeParams, 112);
ICUBE_CHECK_LAYOUT(ViewShadeParams, sun_x, 16);
ICUBE_CHECK_LAYOUT(ViewShadeParams, fx, 32);
ICUBE_CHECK_LAYOUT(ViewShadeParams, depth_max, 48);
ICUBE_CHECK_LAYOUT(ViewShadeParams, m00, 64);

#endif

// Push constants of the viewer's passes (host: viewer/view_renderer.{h,cpp}).
// Shared by GLSL and C++.
//  shaders/view/shade.comp  ViewShadeParams: the picture from the camera hits (+ visibility)
//  shaders/view/rays.comp   ViewRaysParams: shadow / ambient-occlusion rays from the camera hits
//                           for the ray caster's ray-list mode, and their results summed per pixel
#ifndef ICUBE_VIEW_PARAMS_H
#define ICUBE_VIEW_PARAMS_H
#include "gpu_types.h"

#define VIEW_MODE_SHADED 0u
#define VIEW_MODE_SEMANTIC 1u
#define VIEW_MODE_DEPTH 2u
#define VIEW_MODE_INSTANCE 3u
#define VIEW_MODE_COORDS 4u

// Per-pixel visibility word (view/rays.comp writes, view/shade.comp reads):
// bit 16 = the sun ray is blocked, bits 0..15 = AO rays blocked.
#define VIEW_VIS_SHADOW_BIT 65536u
#define VIEW_VIS_AO_MASK 65535u

// ViewRaysParams.flags
#define VIEW_RAYS_INIT 1u         // vis[i] = 0 first
#define VIEW_RAYS_ACCUMULATE 2u   // add the previous pass's hit (binding 1) to vis[i]
#define VIEW_RAYS_PREV_SHADOW 4u  // ... as the sun-shadow bit (else one AO hit)
#define VIEW_RAYS_GENERATE 8u     // write this pass's ray (kind, sample) to binding 3
#define VIEW_RAYS_KIND_SHADOW 0u
#define VIEW_RAYS_KIND_AO 1u

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
  uint use_vis;               // shaded: 1 = read the visibility word (binding 3)
  float ao_scale;             // shaded: ambient · (1 - ao_scale · AO hits)  (= strength / samples)
  // d = normalize(M · (u + o, v + o, 1)), M = R_c2w · K^-1, row-major (for the sky)
  float m00, m01, m02, m10, m11, m12, m20, m21, m22;
  float pad2, pad3, pad4;
};

struct ViewRaysParams {
  uint width, height;
  uint kind;                  // VIEW_RAYS_KIND_*
  uint flags;                 // VIEW_RAYS_*
  int ref_x, ref_y, ref_z;    // the camera rays' reference voxel (RaycastParams ref)
  float pixel_offset;
  float off_x, off_y, off_z;  // camera position - ref corner, voxel units
  float inv_voxel;
  float sun_x, sun_y, sun_z;  // unit, towards the sun
  uint sample_index;          // AO: this ray's index in [0, samples)
  uint samples;               // AO rays per pixel
  float pad0, pad1, pad2;
  float m00, m01, m02, m10, m11, m12, m20, m21, m22;  // as ViewShadeParams
  float pad3, pad4, pad5;
};

ICUBE_SHADER_NAMESPACE_END

ICUBE_CHECK_SIZE(ViewShadeParams, 112);
ICUBE_CHECK_LAYOUT(ViewShadeParams, sun_x, 16);
ICUBE_CHECK_LAYOUT(ViewShadeParams, fx, 32);
ICUBE_CHECK_LAYOUT(ViewShadeParams, depth_max, 48);
ICUBE_CHECK_LAYOUT(ViewShadeParams, use_vis, 56);
ICUBE_CHECK_LAYOUT(ViewShadeParams, m00, 64);
ICUBE_CHECK_SIZE(ViewRaysParams, 128);
ICUBE_CHECK_LAYOUT(ViewRaysParams, ref_x, 16);
ICUBE_CHECK_LAYOUT(ViewRaysParams, off_x, 32);
ICUBE_CHECK_LAYOUT(ViewRaysParams, sun_x, 48);
ICUBE_CHECK_LAYOUT(ViewRaysParams, samples, 64);
ICUBE_CHECK_LAYOUT(ViewRaysParams, m00, 80);

#endif

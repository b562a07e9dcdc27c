// Parameters of the procedural appearance renderer (shaders/appearance/*.comp;
// host module engine/render/appearance/appearance_gpu.h, CPU reference
// appearance_cpu.h; the shading itself: shared/appearance_shading.h).
// Shared by GLSL and C++.
//
// Frames: world z up, metres. Positions the kernels see are relative to the
// camera's reference voxel corner (the ray caster's `ref`, RaycastParams), so
// they stay exact in float 100 km from the origin; procedural textures are
// keyed on the hit voxel's absolute ijk (ints) plus the position inside it,
// so a surface has the same texture from every frame.
// Radiometry: irradiance in kilolux-like units (a clear noon sun ~ 85), sky
// radiance in kcd/m2 (Preetham's Y), so a white Lambertian surface has
// radiance E / pi; `exposure` maps radiance to display before the tone curve.
#ifndef ICUBE_APPEARANCE_PARAMS_H
#define ICUBE_APPEARANCE_PARAMS_H
#include "gpu_types.h"

#define APPEARANCE_FLAG_SHADOWS 1u  // shadow hits are bound (binding 1)
#define APPEARANCE_FLAG_AO 2u       // ambient occlusion probes
#define APPEARANCE_FLAG_SUN 4u      // the sun is above the horizon (direct light, Preetham sky)

// AppearanceLight.kind
#define APPEARANCE_LIGHT_LAMP 0u       // omni street lamp
#define APPEARANCE_LIGHT_HEADLIGHT 1u  // spot along (dx, dy, dz) with cosine cutoff

ICUBE_SHADER_NAMESPACE_BEGIN

struct AppearanceParams {
  // Camera, as the ray caster's camera mode (RaycastParams): pixel (u, v) looks along
  // normalize(M (u + pixel_offset, v + pixel_offset, 1)), M = R K^-1 (row-major).
  float m00, m01, m02, m10, m11, m12, m20, m21, m22;
  float shadow_t_max;  // metres a shadow ray looks for an occluder
  uint table_mask;     // world hash table capacity - 1 (the AO probes' lookups)
  float pad_c0, pad_c1;
  float pixel_offset;
  float voxel_size;  // metres
  uint width, height;
  int ref_x, ref_y, ref_z;  // the ray caster's reference voxel (absolute ijk)
  float off_x, off_y, off_z;  // camera position - ref corner, voxel units
  // Sun: unit direction towards the sun (world), direct irradiance per channel.
  float sun_x, sun_y, sun_z;
  float sun_r, sun_g, sun_b;
  // Preetham sky: Perez coefficients A..E of Y, x, y (15), zenith Y (kcd/m2), x, y, sun zenith angle.
  float perez[15];
  float zenith_Y, zenith_x, zenith_y, theta_s;
  // Overcast sky (CIE overcast, used with weight `overcast`): zenith luminance; the night sky
  // (weight `night`): zenith and horizon radiance per channel.
  float overcast, overcast_Y, night, night_pad;
  float night_zr, night_zg, night_zb;
  float night_hr, night_hg, night_hb;
  // Ambient irradiance from the sky on an up-facing and a down-facing surface (ground bounce).
  float amb_up_r, amb_up_g, amb_up_b;
  float amb_dn_r, amb_dn_g, amb_dn_b;
  // Fog: extinction per metre and its colour (radiance); weather.
  float fog_density, fog_r, fog_g, fog_b;
  float wetness, snow, exposure, window_lit;  // window_lit: fraction of lit windows (night)
  // Season tint of foliage (linear albedo) and its variation.
  float veg_r, veg_g, veg_b, veg_var;
  uint seed, light_count, flags, pad0;
  float ao_strength, lamp_range, sun_disc, pad1;
};

// One light (kind: APPEARANCE_LIGHT_*): position relative to the ref corner (metres), range
// (metres: the falloff 1 / (1 + (d / range)^2) ends at 4 range), direction and cosine cutoff
// for spots, radiant intensity per channel.
struct AppearanceLight {
  float px, py, pz, range;
  float dx, dy, dz, cos_cut;
  float r, g, b;
  uint kind;
};

// Push constants of appearance/shadow_rays and appearance/shade: the window of pixels [first, end)
// one dispatch handles; its outputs (shadow rays, rgba, labels) are bound from pixel `first`, so an
// image over one storage binding is shaded in windows (one window: first 0, end W·H).
struct AppearanceWindow {
  uint first;
  uint end;
};

ICUBE_SHADER_NAMESPACE_END

ICUBE_CHECK_SIZE(AppearanceWindow, 8);
ICUBE_CHECK_SIZE(AppearanceParams, 336);
ICUBE_CHECK_LAYOUT(AppearanceParams, width, 60);
ICUBE_CHECK_LAYOUT(AppearanceParams, ref_x, 68);
ICUBE_CHECK_LAYOUT(AppearanceParams, sun_x, 92);
ICUBE_CHECK_LAYOUT(AppearanceParams, perez, 116);
ICUBE_CHECK_LAYOUT(AppearanceParams, zenith_Y, 176);
ICUBE_CHECK_LAYOUT(AppearanceParams, overcast, 192);
ICUBE_CHECK_LAYOUT(AppearanceParams, fog_density, 256);
ICUBE_CHECK_LAYOUT(AppearanceParams, seed, 304);
ICUBE_CHECK_LAYOUT(AppearanceParams, ao_strength, 320);
ICUBE_CHECK_SIZE(AppearanceLight, 48);
ICUBE_CHECK_LAYOUT(AppearanceLight, dx, 16);
ICUBE_CHECK_LAYOUT(AppearanceLight, kind, 44);

#endif

// Sun, sky, ambient, fog, weather and exposure of a procedural appearance
// frame from the parsed prompt (prompt.h): the non-camera fields of
// shader::AppearanceParams.
// - Sun: elevation and azimuth by time of day (noon 58 deg, morning and
//   afternoon 30, dawn and dusk 4, night -20: no sun), world z up, azimuth
//   CCW from +x; direct irradiance 100 x exp(-tau m) per channel with the
//   Kasten-Young air mass m, tau = (0.09, 0.13, 0.25) x turbidity / 2.5.
// - Clear sky: Preetham, Shirley and Smits (1999), turbidity 2.5 (dawn and
//   dusk 3.5, partly cloudy 4); Perez coefficients and zenith Y, x, y as in
//   the paper, Y in kcd/m2; stored divided by F(0, theta_s) so the kernel
//   evaluates zenith * F(theta, gamma).
// - Overcast sky: CIE overcast L = Lz (1 + 2 cos theta) / 3, mixed in with
//   weight `overcast` (overcast 1, partly cloudy 0.5, rainy 1, foggy 0.8,
//   snowy 0.7); direct sun scaled by 1 - 0.95 overcast.
// - Night: a dark blue zenith and a sodium-tinted horizon glow; lamps,
//   headlights and lit windows (lights.h) carry the scene.
// - Ambient: the sky's cosine-weighted integral over the upper hemisphere for
//   an up-facing surface, the ground's bounce (albedo 0.15) for a down-facing
//   one; integrated numerically with the same model the kernel evaluates.
// - Fog: extinction 3.9 / visibility (foggy: 80 m / intensity; other weather:
//   2 km haze, rainy 600 m), colour = the ambient-lit grey.
// - Exposure: 0.65 / E^0.6 with E the horizontal irradiance (sun + sky +
//   0.02 for artificial light): it compensates only part of the change, so
//   dusk stays dim and night dark.
#pragma once

#include "render/appearance/prompt.h"
#include "shared/appearance_params.h"

#include <cstdint>

namespace icube::render {

struct SunPosition {
  double elevation_deg = 0.0, azimuth_deg = 0.0;
};
SunPosition sun_position(TimeOfDay t);

// Every field but the camera's (m00..m22, pixel_offset, voxel_size, width, height, ref, off),
// table_mask, light_count and the shadow/AO flags.
shader::AppearanceParams lighting_params(const AppearancePrompt& prompt, uint32_t seed);

}  // namespace icube::render

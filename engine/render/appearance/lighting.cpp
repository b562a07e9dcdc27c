// Lighting set-up from the prompt; see lighting.h.
#include "render/appearance/lighting.h"

#include "render/appearance/shading_cpu.h"

#include <algorithm>
#include <cmath>

namespace icube::render {

namespace {

constexpr double kPi = 3.14159265358979323846;

// Preetham et al. (1999), appendix: Perez coefficients (A..E) of Y, x, y as linear functions of T.
void preetham_coefficients(double T, float* perez) {
  const double c[15][2] = {
      {0.1787, -1.4630},  {-0.3554, 0.4275}, {-0.0227, 5.3251}, {0.1206, -2.5771}, {-0.0670, 0.3703},
      {-0.0193, -0.2592}, {-0.0665, 0.0008}, {-0.0004, 0.2125}, {-0.0641, -0.8989}, {-0.0033, 0.0452},
      {-0.0167, -0.2608}, {-0.0950, 0.0092}, {-0.0079, 0.2102}, {-0.0441, -1.6537}, {-0.0109, 0.0529}};
  for (int i = 0; i < 15; ++i) perez[i] = static_cast<float>(c[i][0] * T + c[i][1]);
}

double perez_f(const float* k, double theta, double gamma) {
  return (1.0 + double{k[0]} * std::exp(double{k[1]} / std::cos(theta))) *
         (1.0 + double{k[2]} * std::exp(double{k[3]} * gamma) + double{k[4]} * std::cos(gamma) * std::cos(gamma));
}

struct Look {
  double turbidity = 2.5, overcast = 0.0, overcast_Y = 5.0, wet = 0.0, snow = 0.0, visibility_m = 2000.0;
};

Look look_of(const AppearancePrompt& p) {
  Look l;
  const double s = std::clamp(double{p.intensity}, 0.25, 2.0);
  if (p.time == TimeOfDay::Dawn || p.time == TimeOfDay::Dusk) l.turbidity = 3.5;
  switch (p.weather) {
    case Weather::Sunny: break;
    case Weather::PartlyCloudy: l.overcast = 0.5, l.turbidity = 4.0; break;
    case Weather::Overcast: l.overcast = 1.0, l.overcast_Y = 5.0; break;
    case Weather::Rainy:
      l.overcast = 1.0, l.overcast_Y = 3.0, l.wet = std::min(1.0, 0.7 * s), l.visibility_m = 600.0 / s;
      break;
    case Weather::Foggy: l.overcast = 0.8, l.overcast_Y = 4.0, l.visibility_m = 80.0 / s; break;
    case Weather::Snowy: l.overcast = 0.7, l.overcast_Y = 5.0, l.snow = std::min(1.0, 0.8 * s), l.visibility_m = 800.0 / s; break;
  }
  return l;
}

}  // namespace

SunPosition sun_position(TimeOfDay t) {
  switch (t) {
    case TimeOfDay::Dawn: return {4.0, 80.0};
    case TimeOfDay::Morning: return {30.0, 110.0};
    case TimeOfDay::Noon: return {58.0, 180.0};
    case TimeOfDay::Afternoon: return {30.0, 250.0};
    case TimeOfDay::Dusk: return {4.0, 280.0};
    case TimeOfDay::Night: return {-20.0, 0.0};
  }
  return {58.0, 180.0};
}

shader::AppearanceParams lighting_params(const AppearancePrompt& prompt, uint32_t seed) {
  shading::Shader S;
  shader::AppearanceParams& P = S.P;
  P = shader::AppearanceParams{};
  P.seed = seed;
  P.ao_strength = 0.85f;
  P.lamp_range = 6.0f;
  P.sun_disc = 0.0f;
  const Look look = look_of(prompt);
  const SunPosition sp = sun_position(prompt.time);
  const double el = sp.elevation_deg * kPi / 180.0, az = sp.azimuth_deg * kPi / 180.0;
  P.sun_x = static_cast<float>(std::cos(el) * std::cos(az));
  P.sun_y = static_cast<float>(std::cos(el) * std::sin(az));
  P.sun_z = static_cast<float>(std::sin(el));
  const bool sun_up = sp.elevation_deg > 0.0;
  if (sun_up) {
    P.flags |= APPEARANCE_FLAG_SUN;
    // Direct sun: Kasten-Young air mass, per-channel optical depth.
    const double m = 1.0 / (std::sin(el) + 0.50572 * std::pow(sp.elevation_deg + 6.07995, -1.6364));
    const double tau_scale = look.turbidity / 2.5, direct = 100.0 * (1.0 - 0.95 * look.overcast);
    P.sun_r = static_cast<float>(direct * std::exp(-0.09 * tau_scale * m));
    P.sun_g = static_cast<float>(direct * std::exp(-0.13 * tau_scale * m));
    P.sun_b = static_cast<float>(direct * std::exp(-0.25 * tau_scale * m));
    P.sun_disc = static_cast<float>(2000.0 * (1.0 - look.overcast));
    // Preetham: zenith values, normalised by F(0, theta_s).
    const double T = look.turbidity, ts = kPi / 2.0 - el;
    const double chi = (4.0 / 9.0 - T / 120.0) * (kPi - 2.0 * ts);
    const double Yz = std::max(0.05, (4.0453 * T - 4.9710) * std::tan(chi) - 0.2155 * T + 2.4192);
    const double t3 = ts * ts * ts, t2 = ts * ts;
    const double xz = T * T * (0.00166 * t3 - 0.00375 * t2 + 0.00209 * ts) +
                      T * (-0.02903 * t3 + 0.06377 * t2 - 0.03202 * ts + 0.00394) +
                      (0.11693 * t3 - 0.21196 * t2 + 0.06052 * ts + 0.25886);
    const double yz = T * T * (0.00275 * t3 - 0.00610 * t2 + 0.00317 * ts) +
                      T * (-0.04214 * t3 + 0.08970 * t2 - 0.04153 * ts + 0.00516) +
                      (0.15346 * t3 - 0.26756 * t2 + 0.06670 * ts + 0.26688);
    preetham_coefficients(T, P.perez);
    P.zenith_Y = static_cast<float>(Yz / perez_f(P.perez, 0.0, ts));
    P.zenith_x = static_cast<float>(xz / perez_f(P.perez + 5, 0.0, ts));
    P.zenith_y = static_cast<float>(yz / perez_f(P.perez + 10, 0.0, ts));
    P.theta_s = static_cast<float>(ts);
    // The overcast sky dims with a low sun.
    P.overcast_Y = static_cast<float>(look.overcast_Y * std::clamp(std::sin(el) / std::sin(58.0 * kPi / 180.0), 0.08, 1.0));
  } else {
    P.overcast_Y = static_cast<float>(look.overcast_Y * 0.0001);
  }
  P.overcast = static_cast<float>(look.overcast);
  P.night = sun_up ? 0.0f : 1.0f;
  P.night_zr = 0.0004f, P.night_zg = 0.0007f, P.night_zb = 0.0018f;
  P.night_hr = 0.0040f, P.night_hg = 0.0028f, P.night_hb = 0.0016f;
  P.wetness = static_cast<float>(look.wet);
  P.snow = static_cast<float>(look.snow);
  P.window_lit = sun_up ? (sp.elevation_deg < 10.0 ? 0.25f : 0.0f) : 0.55f;
  // Foliage by season.
  switch (prompt.season) {
    case Season::Summer: P.veg_r = 0.060f, P.veg_g = 0.120f, P.veg_b = 0.030f, P.veg_var = 0.3f; break;
    case Season::Spring: P.veg_r = 0.090f, P.veg_g = 0.170f, P.veg_b = 0.040f, P.veg_var = 0.3f; break;
    case Season::Autumn: P.veg_r = 0.250f, P.veg_g = 0.110f, P.veg_b = 0.025f, P.veg_var = 0.6f; break;
    case Season::Winter: P.veg_r = 0.090f, P.veg_g = 0.075f, P.veg_b = 0.055f, P.veg_var = 0.2f; break;
  }
  // Ambient: the sky's irradiance on an up-facing surface (midpoint rule, 24 x 48 directions).
  glm::dvec3 e_up(0.0);
  const int nt = 24, np = 48;
  for (int i = 0; i < nt; ++i) {
    const double th = (i + 0.5) * (kPi / 2.0) / nt;
    for (int j = 0; j < np; ++j) {
      const double ph = (j + 0.5) * 2.0 * kPi / np;
      const glm::vec3 d(static_cast<float>(std::sin(th) * std::cos(ph)), static_cast<float>(std::sin(th) * std::sin(ph)),
                        static_cast<float>(std::cos(th)));
      const glm::vec3 L = S.shade_sky(d);
      e_up += glm::dvec3(L) * (std::cos(th) * std::sin(th) * (kPi / 2.0 / nt) * (2.0 * kPi / np));
    }
  }
  const double sun_h = sun_up ? double{P.sun_z} : 0.0;
  const glm::dvec3 sun_rgb(P.sun_r, P.sun_g, P.sun_b);
  const glm::dvec3 e_dn = 0.15 * (e_up + sun_rgb * sun_h) * 0.5;
  P.amb_up_r = static_cast<float>(e_up.x), P.amb_up_g = static_cast<float>(e_up.y), P.amb_up_b = static_cast<float>(e_up.z);
  P.amb_dn_r = static_cast<float>(e_dn.x), P.amb_dn_g = static_cast<float>(e_dn.y), P.amb_dn_b = static_cast<float>(e_dn.z);
  // Fog and haze.
  P.fog_density = static_cast<float>(3.9 / look.visibility_m);
  const glm::dvec3 fog = (e_up + sun_rgb * sun_h * (1.0 - look.overcast) * 0.3) * (0.8 / kPi);
  P.fog_r = static_cast<float>(fog.x), P.fog_g = static_cast<float>(fog.y), P.fog_b = static_cast<float>(fog.z);
  // Exposure from the horizontal irradiance.
  const double e_h = (e_up.x + e_up.y + e_up.z) / 3.0 + sun_h * (sun_rgb.x + sun_rgb.y + sun_rgb.z) / 3.0 + 0.02;
  P.exposure = static_cast<float>(0.65 / std::pow(e_h, 0.6));
  return P;
}

}  // namespace icube::render

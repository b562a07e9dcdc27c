// The procedural appearance model: per-class materials with world-fixed
// detail, the sky (Preetham clear sky, CIE overcast, night), sun, ambient,
// ambient-occlusion probes, street lamps and headlights, wet and snowy
// ground, fog, and the tone curve. Written once in the common subset of GLSL
// and C++/GLM and compiled twice: by shaders/appearance/shade.comp (with
// `P` the AppearanceParams of the bound buffer) and by the CPU reference
// engine/render/appearance/appearance_cpu.cpp (inside a struct whose member
// `P` is the same parameters), so the two sides cannot drift apart; what they
// feed it (hits, shadow rays, occupancy probes) comes from their own ray
// casters and world lookups.
// Rules for this file: float literals with an `f`, explicit conversions, no
// swizzles beyond .x/.y/.z, no out parameters, functions declared before use.
// Texture space: a surface point is (ijk, local): the hit voxel's absolute
// ijk (ints) and the point inside it in [0, 1]^3, so the detail is fixed to
// the world and exact at any distance from the origin.
// Classes: engine/world/semantics.h (Waymo's 23).
#ifndef ICUBE_APPEARANCE_SHADING_H
#define ICUBE_APPEARANCE_SHADING_H

#ifdef __cplusplus
#define SHADE_CONST static constexpr
#else
#define SHADE_CONST const
#endif

SHADE_CONST float kShadePi = 3.14159265f;
SHADE_CONST int kShadeAoProbes = 10;

// ---- hashing and world-fixed noise -------------------------------------------------------------

uint shade_hash(uint x) {
  x ^= x >> 16u;
  x *= 0x7feb352du;
  x ^= x >> 15u;
  x *= 0x846ca68bu;
  x ^= x >> 16u;
  return x;
}

// One mixing round over the three coordinates (cheap enough to run 24 times a pixel).
uint shade_hash3(ivec3 c, uint salt) {
  return shade_hash((uint(c.x) * 0x8da6b343u) ^ (uint(c.y) * 0xd8163841u) ^ (uint(c.z) * 0xcb1ab31fu) ^
                    (salt * 0x68e31da4u + P.seed * 0x9e3779b9u));
}

// Uniform in [0, 1).
float shade_rand(ivec3 c, uint salt) { return float(shade_hash3(c, salt) >> 8u) * (1.0f / 16777216.0f); }

int shade_floor_div(int a, int b) { return a >= 0 ? a / b : (a - b + 1) / b; }
int shade_mod(int a, int b) { return a - shade_floor_div(a, b) * b; }

// Smooth value noise in [0, 1) with lattice spacing `cell` / `sub` voxels (cell, sub >= 1) at the
// point (ijk, local); `flat_z` ignores z (2-D patterns on the ground and roofs).
float shade_noise(ivec3 ijk, vec3 local, int cell, int sub, uint salt, bool flat_z) {
  ivec3 base = ivec3(0);
  vec3 f = vec3(0.0f);
  for (int a = 0; a < 3; ++a) {
    const float ls = clamp(local[a], 0.0f, 0.999999f) * float(sub);
    const int fine = ijk[a] * sub + int(floor(ls));
    base[a] = shade_floor_div(fine, cell);
    f[a] = (float(shade_mod(fine, cell)) + fract(ls)) / float(cell);
  }
  if (flat_z) {
    base.z = 0;
    f.z = 0.0f;
  }
  const vec3 w = f * f * (vec3(3.0f) - 2.0f * f);
  float acc = 0.0f;
  for (int c = 0; c < 8; ++c) {
    const ivec3 o = ivec3(c & 1, (c >> 1) & 1, (c >> 2) & 1);
    const float wx = o.x == 1 ? w.x : 1.0f - w.x;
    const float wy = o.y == 1 ? w.y : 1.0f - w.y;
    const float wz = o.z == 1 ? w.z : 1.0f - w.z;
    acc += wx * wy * wz * shade_rand(base + o, salt);
  }
  return acc;
}

// ---- materials ---------------------------------------------------------------------------------

struct ShadeMaterial {
  vec3 albedo;  // linear
  float f0;     // specular reflectance at normal incidence (0: matte)
  vec3 emit;    // emitted radiance
  float gloss;  // 0..1: sharpness of the sun highlight
};

ShadeMaterial shade_matte(vec3 albedo) {
  ShadeMaterial m;
  m.albedo = albedo;
  m.f0 = 0.0f;
  m.emit = vec3(0.0f);
  m.gloss = 0.0f;
  return m;
}

vec3 shade_palette_car(uint h) {
  const uint k = h % 10u;
  if (k == 0u) return vec3(0.80f, 0.80f, 0.78f);   // white
  if (k == 1u) return vec3(0.02f, 0.02f, 0.025f);  // black
  if (k == 2u) return vec3(0.42f, 0.43f, 0.45f);   // silver
  if (k == 3u) return vec3(0.14f, 0.145f, 0.15f);  // grey
  if (k == 4u) return vec3(0.45f, 0.03f, 0.025f);  // red
  if (k == 5u) return vec3(0.03f, 0.08f, 0.32f);   // blue
  if (k == 6u) return vec3(0.75f, 0.76f, 0.74f);   // white
  if (k == 7u) return vec3(0.03f, 0.03f, 0.035f);  // black
  if (k == 8u) return vec3(0.25f, 0.22f, 0.16f);   // beige
  return vec3(0.05f, 0.16f, 0.08f);                // green
}

vec3 shade_palette_facade(uint h) {
  const uint k = h % 6u;
  if (k == 0u) return vec3(0.35f, 0.13f, 0.08f);  // brick
  if (k == 1u) return vec3(0.48f, 0.42f, 0.33f);  // sandstone
  if (k == 2u) return vec3(0.36f, 0.36f, 0.35f);  // concrete
  if (k == 3u) return vec3(0.62f, 0.60f, 0.56f);  // render
  if (k == 4u) return vec3(0.22f, 0.20f, 0.19f);  // dark stone
  return vec3(0.50f, 0.36f, 0.24f);               // ochre
}

bool shade_is_vehicle(uint cls) { return cls >= 1u && cls <= 4u; }
bool shade_is_ground(uint cls) { return cls >= 17u && cls <= 22u; }

// The three noises a material reads, with lattice spacings chosen by class (one evaluation of
// each per pixel: on CPU-style SIMD every branch of the class chain runs, so the noise is
// computed once outside it). fine: 1 voxel / sub; mid: 1 m; coarse: 2 m, flat.
int shade_fine_sub(uint cls) {
  return cls == 18u ? 5 : (cls == 16u ? 6 : (cls == 15u ? 2 : (cls == 20u ? 3 : 4)));
}

struct ShadeNoise {
  float fine, mid, coarse;
};

ShadeNoise shade_noises(uint cls, ivec3 ijk, vec3 local) {
  ShadeNoise z;
  // Bark streaks: the fine noise ignores height on trunks.
  const vec3 lf = cls == 16u ? vec3(local.x, local.y, 0.5f) : local;
  const ivec3 jf = cls == 16u ? ivec3(ijk.x, ijk.y, 0) : ijk;
  z.fine = shade_noise(jf, lf, 1, shade_fine_sub(cls), 1u, false);
  z.mid = shade_noise(ijk, local, 5, 1, 2u, cls == 18u || cls == 20u);
  z.coarse = shade_noise(ijk, local, 10, 1, 3u, true);
  return z;
}

// n: the outward face normal (one axis, +-1); tangent axes t1 = (a + 1) % 3, t2 = (a + 2) % 3.
ShadeMaterial shade_material(uint cls, uint inst, ivec3 ijk, vec3 local, ivec3 n) {
  const int axis = n.x != 0 ? 0 : (n.y != 0 ? 1 : 2);
  const bool up = n.z > 0;
  const bool vertical = axis != 2;
  const ShadeNoise z = shade_noises(cls, ijk, local);
  ShadeMaterial m = shade_matte(vec3(0.3f));
  if (cls == 18u) {  // road: asphalt grain (4 cm) over 1 m patches
    const float g = 0.075f + 0.045f * z.fine + 0.03f * z.mid;
    m = shade_matte(vec3(g, g, g * 1.04f));
    m.f0 = 0.02f;
    m.gloss = 0.2f;
  } else if (cls == 19u) {  // lane paint, worn
    m = shade_matte(vec3(0.72f, 0.71f, 0.66f) * (0.75f + 0.25f * (1.0f - z.fine)));
    m.f0 = 0.03f;
    m.gloss = 0.3f;
  } else if (cls == 17u) {  // kerb stone, 1 m blocks
    const float st = 0.30f + 0.08f * z.fine;
    const int t = vertical ? (axis == 0 ? 1 : 0) : 0;
    const float along = float(shade_mod(ijk[t], 5)) + local[t];
    m = shade_matte(vec3(st, st * 0.98f, st * 0.95f) * (along < 0.12f ? 0.55f : 1.0f));
  } else if (cls == 21u || cls == 22u) {  // paving: 0.4 m tiles with joints
    const ivec3 tile = ivec3(shade_floor_div(ijk.x, 2), shade_floor_div(ijk.y, 2), 0);
    const float tint = 0.85f + 0.3f * shade_rand(tile, 5u);
    const float ux = float(shade_mod(ijk.x, 2)) + local.x, uy = float(shade_mod(ijk.y, 2)) + local.y;
    const bool joint = up && (ux < 0.05f || uy < 0.05f);
    const vec3 base = cls == 22u ? vec3(0.36f, 0.34f, 0.31f) : vec3(0.30f, 0.29f, 0.27f);
    m = shade_matte(base * tint * (joint ? 0.75f : 1.0f) * (0.9f + 0.2f * z.fine));
  } else if (cls == 20u) {  // other ground: grass and dirt
    const vec3 grass = vec3(P.veg_r, P.veg_g, P.veg_b) * 0.8f;
    m = shade_matte(mix(grass, vec3(0.20f, 0.15f, 0.10f), smoothstep(0.35f, 0.65f, z.coarse)) * (0.8f + 0.4f * z.fine));
  } else if (cls == 14u) {  // building: facade colour per 8 m block, windows on floors of 3.2 m
    const ivec3 block = ivec3(shade_floor_div(ijk.x, 40), shade_floor_div(ijk.y, 40), 0);
    m = shade_matte(shade_palette_facade(shade_hash3(block, 9u)) * (0.9f + 0.2f * z.fine));
    if (up) {
      m = shade_matte(vec3(0.11f, 0.11f, 0.115f) * (0.8f + 0.4f * z.mid));
    } else if (vertical) {
      const int t = axis == 0 ? 1 : 0;
      const int cu = shade_mod(ijk[t], 10), cz = shade_mod(ijk.z, 16);
      if (cu >= 3 && cu <= 7 && cz >= 5 && cz <= 11) {
        const ivec3 window = ivec3(shade_floor_div(ijk[t], 10), shade_floor_div(ijk.z, 16), ijk[axis] * 2 + n[axis]);
        const uint wh = shade_hash3(window, 12u);
        m = shade_matte(vec3(0.035f, 0.045f, 0.055f));
        m.f0 = 0.25f;
        m.gloss = 0.9f;
        if (float(wh & 0xffffu) * (1.0f / 65536.0f) < P.window_lit)
          m.emit = vec3(1.0f, 0.72f, 0.42f) * (0.6f + 0.8f * float(wh >> 16u) * (1.0f / 65536.0f)) * 0.12f;
      }
    }
  } else if (cls == 15u) {  // foliage
    const float k = (0.55f + 0.9f * z.fine) * (0.75f + 0.5f * z.mid);
    const float hue = z.coarse - 0.5f;
    const vec3 veg = vec3(P.veg_r, P.veg_g, P.veg_b) * (vec3(1.0f) + P.veg_var * vec3(hue, -0.5f * hue, -hue));
    m = shade_matte(veg * k);
  } else if (cls == 16u) {  // bark: vertical streaks
    m = shade_matte(vec3(0.13f, 0.09f, 0.06f) * (0.6f + 0.8f * z.fine));
  } else if (cls == 10u) {  // pole: galvanised metal
    m = shade_matte(vec3(0.33f, 0.34f, 0.36f));
    m.f0 = 0.3f;
    m.gloss = 0.5f;
  } else if (cls == 8u) {  // sign
    const uint k = shade_hash3(ivec3(shade_floor_div(ijk.x, 8), shade_floor_div(ijk.y, 8), 0), 18u) % 4u;
    m = shade_matte(k == 0u ? vec3(0.04f, 0.12f, 0.45f)
                            : (k == 1u ? vec3(0.5f, 0.04f, 0.03f) : (k == 2u ? vec3(0.7f) : vec3(0.04f, 0.28f, 0.09f))));
    m.f0 = 0.05f;
    m.gloss = 0.4f;
  } else if (cls == 9u) {  // traffic light housing
    m = shade_matte(vec3(0.03f, 0.035f, 0.03f));
  } else if (shade_is_vehicle(cls)) {  // car paint per instance, clear coat
    const uint h = inst != 0u ? shade_hash(inst * 0x2c1b3c6du + P.seed)
                              : shade_hash3(ivec3(shade_floor_div(ijk.x, 25), shade_floor_div(ijk.y, 25), 0), 19u);
    m = shade_matte(shade_palette_car(h));
    m.f0 = 0.08f;
    m.gloss = 0.85f;
  } else if (cls >= 5u && cls <= 7u) {  // people: clothing per instance
    const uint h = shade_hash(inst * 0x51ed27u + 7u + P.seed);
    m = shade_matte(vec3(float(h & 255u), float((h >> 8u) & 255u), float((h >> 16u) & 255u)) * (0.5f / 255.0f));
  } else if (cls == 11u) {  // construction cone
    m = shade_matte(vec3(0.80f, 0.22f, 0.02f));
  } else if (cls == 12u || cls == 13u) {  // bicycles, motorcycles
    m = shade_matte(vec3(0.08f, 0.08f, 0.09f));
    m.f0 = 0.2f;
    m.gloss = 0.6f;
  }
  // Weather on up-facing surfaces: snow cover (tyre-worn on roads), then wet ground with puddles.
  if (up && P.snow > 0.0f) {
    float cover = 1.0f;
    if (cls == 18u || cls == 19u) cover = smoothstep(0.3f, 0.7f, z.mid) * 0.7f;
    else if (cls == 15u) cover = 0.75f;
    cover *= P.snow;
    m.albedo = mix(m.albedo, vec3(0.82f, 0.84f, 0.88f) * (0.92f + 0.08f * z.fine), cover);
    m.f0 = mix(m.f0, 0.02f, cover);
    m.emit = m.emit * (1.0f - cover);
  }
  if (P.wetness > 0.0f && (shade_is_ground(cls) || (up && !shade_is_vehicle(cls)))) {
    const float puddle = up ? smoothstep(0.55f, 0.7f, z.coarse) : 0.0f;
    m.albedo = m.albedo * (1.0f - 0.45f * P.wetness - 0.3f * puddle * P.wetness);
    m.f0 = max(m.f0, P.wetness * (0.05f + 0.25f * puddle));
    m.gloss = max(m.gloss, P.wetness * (0.6f + 0.4f * puddle));
  }
  return m;
}

// ---- sky and lights ----------------------------------------------------------------------------

float shade_perez(int k, float cos_theta, float gamma, float cos_gamma) {
  const float a = P.perez[5 * k], b = P.perez[5 * k + 1], c = P.perez[5 * k + 2], d = P.perez[5 * k + 3],
              e = P.perez[5 * k + 4];
  return (1.0f + a * exp(b / cos_theta)) * (1.0f + c * exp(d * gamma) + e * cos_gamma * cos_gamma);
}

vec3 shade_xyY_to_rgb(float x, float y, float Y) {
  const float X = x / y * Y, Z = (1.0f - x - y) / y * Y;
  return vec3(3.2404542f * X - 1.5371385f * Y - 0.4985314f * Z, -0.9692660f * X + 1.8760108f * Y + 0.0415560f * Z,
              0.0556434f * X - 0.2040259f * Y + 1.0572252f * Z);
}

vec3 shade_sun_dir() { return vec3(P.sun_x, P.sun_y, P.sun_z); }

// Sky radiance (kcd/m2 per channel) seen along unit direction d, without the sun disc.
vec3 shade_sky(vec3 d) {
  const float dz = max(d.z, 0.0f);
  const float cos_theta = max(dz, 0.02f);
  vec3 sky = vec3(0.0f);
  if ((P.flags & APPEARANCE_FLAG_SUN) != 0u) {
    const float cos_gamma = clamp(dot(d, shade_sun_dir()), -1.0f, 1.0f);
    const float gamma = acos(cos_gamma);
    const float Y = P.zenith_Y * shade_perez(0, cos_theta, gamma, cos_gamma);
    const float x = P.zenith_x * shade_perez(1, cos_theta, gamma, cos_gamma);
    const float y = P.zenith_y * shade_perez(2, cos_theta, gamma, cos_gamma);
    sky = max(shade_xyY_to_rgb(x, y, Y), vec3(0.0f));
  }
  const vec3 overcast = vec3(0.95f, 0.98f, 1.05f) * (P.overcast_Y * (1.0f + 2.0f * cos_theta) / 3.0f);
  sky = mix(sky, overcast, P.overcast);
  const vec3 night = mix(vec3(P.night_hr, P.night_hg, P.night_hb), vec3(P.night_zr, P.night_zg, P.night_zb), sqrt(dz));
  sky = mix(sky, night, P.night);
  // Below the horizon (past the world's edge): the horizon, darkened like distant ground.
  return d.z < 0.0f ? sky * 0.55f : sky;
}

vec3 shade_ambient(vec3 nrm) {
  return mix(vec3(P.amb_dn_r, P.amb_dn_g, P.amb_dn_b), vec3(P.amb_up_r, P.amb_up_g, P.amb_up_b), 0.5f + 0.5f * nrm.z);
}

// Irradiance at `pos` (metres, ref frame) on a surface with normal nrm from one light.
vec3 shade_light(vec3 lpos, float range, vec3 ldir, float cos_cut, vec3 intensity, uint kind, vec3 pos, vec3 nrm) {
  const vec3 to = lpos - pos;
  const float d2 = max(dot(to, to), 1e-4f);
  const float d = sqrt(d2);
  const vec3 l = to / d;
  float k = max(dot(nrm, l), 0.0f) / (1.0f + d2 / (range * range)) * smoothstep(4.0f * range, 2.0f * range, d);
  if (kind == APPEARANCE_LIGHT_HEADLIGHT) k *= smoothstep(cos_cut, cos_cut + 0.25f * (1.0f - cos_cut), dot(-l, ldir));
  return intensity * k;
}

// ---- ambient occlusion probes ------------------------------------------------------------------

// Probe k (0 .. kShadeAoProbes - 1) of the face with outward normal n of voxel ijk: cells of a
// few short rays from the face (along n, along the face and diagonally up from it), starting
// at the empty cell c = ijk + n in front of the face.
ivec3 shade_ao_probe(int k, ivec3 ijk, ivec3 n) {
  const int axis = n.x != 0 ? 0 : (n.y != 0 ? 1 : 2);
  ivec3 t1 = ivec3(0), t2 = ivec3(0);
  t1[(axis + 1) % 3] = 1;
  t2[(axis + 2) % 3] = 1;
  const ivec3 c = ijk + n;
  if (k == 0) return c + n;
  if (k == 1) return c + 2 * n;
  const int j = (k - 2) % 4;
  const ivec3 t = j == 0 ? t1 : (j == 1 ? -t1 : (j == 2 ? t2 : -t2));
  return k < 6 ? c + t : c + t + n;
}

float shade_ao_weight(int k) { return k == 0 ? 1.0f : (k == 1 ? 0.5f : (k < 6 ? 0.5f : 0.35f)); }

// Occlusion from the weights of the occupied probes (sum over k of shade_ao_weight(k)).
float shade_ao(float occluded) { return 1.0f - P.ao_strength * clamp(occluded / 4.4f, 0.0f, 1.0f); }

// ---- the pixel ---------------------------------------------------------------------------------

// Radiance leaving a surface point towards the camera (without fog). view: unit vector from
// the point to the camera; sun_vis: 1 lit, 0 in shadow; lights: irradiance from lamps and
// headlights; refl: sky radiance along the mirror direction.
vec3 shade_surface(ShadeMaterial m, vec3 nrm, vec3 view, float sun_vis, float ao, vec3 lights) {
  const vec3 sun = shade_sun_dir();
  const float ndl = max(dot(nrm, sun), 0.0f);
  vec3 e = shade_ambient(nrm) * ao + lights;
  const bool sun_up = (P.flags & APPEARANCE_FLAG_SUN) != 0u;
  if (sun_up) e += vec3(P.sun_r, P.sun_g, P.sun_b) * (ndl * sun_vis);
  vec3 col = m.albedo * e * (1.0f / kShadePi);
  if (m.f0 > 0.0f) {
    const float cosv = clamp(dot(nrm, view), 0.0f, 1.0f);
    const float f = m.f0 + (1.0f - m.f0) * pow(1.0f - cosv, 5.0f) * m.gloss;
    const vec3 r = reflect(-view, nrm);
    col = col * (1.0f - f) + f * shade_sky(r) * (r.z > 0.0f ? 1.0f : 0.35f) * ao;
    if (sun_up) {
      const float shin = 8.0f + 400.0f * m.gloss * m.gloss;
      const float spec = pow(max(dot(r, sun), 0.0f), shin) * (shin + 2.0f) / (2.0f * kShadePi);
      col += f * vec3(P.sun_r, P.sun_g, P.sun_b) * (spec * ndl * sun_vis);
    }
  }
  return col + m.emit;
}

vec3 shade_fog(vec3 col, float dist) {
  const float k = exp(-P.fog_density * dist);
  return mix(vec3(P.fog_r, P.fog_g, P.fog_b), col, k);
}

// Sky pixel: the sky, the sun's disc and the haze of a long path.
vec3 shade_sky_pixel(vec3 d) {
  vec3 col = shade_sky(d);
  if ((P.flags & APPEARANCE_FLAG_SUN) != 0u && dot(d, shade_sun_dir()) > 0.99998f && P.sun_disc > 0.0f)
    col += vec3(P.sun_r, P.sun_g, P.sun_b) * P.sun_disc;
  return shade_fog(col, 600.0f);
}

// Radiance -> display: exposure, a filmic curve (Narkowicz's ACES fit), sRGB encoding, RGBA8
// with `alpha` (255: a surface, 0: sky).
float shade_srgb(float x) {
  return x <= 0.0031308f ? 12.92f * x : 1.055f * pow(x, 1.0f / 2.4f) - 0.055f;
}

uint shade_encode(vec3 radiance, uint alpha) {
  const vec3 x = max(radiance * P.exposure, vec3(0.0f));
  const vec3 t = clamp((x * (2.51f * x + vec3(0.03f))) / (x * (2.43f * x + vec3(0.59f)) + vec3(0.14f)), 0.0f, 1.0f);
  const uint r = uint(shade_srgb(t.x) * 255.0f + 0.5f), g = uint(shade_srgb(t.y) * 255.0f + 0.5f),
             b = uint(shade_srgb(t.z) * 255.0f + 0.5f);
  return r | (g << 8u) | (b << 16u) | (alpha << 24u);
}

// Outward face normal of RaycastHit.normal (+-(axis + 1)); none (0): against the ray.
ivec3 shade_face_normal(int code, vec3 dir) {
  ivec3 n = ivec3(0);
  if (code == 0) {
    const vec3 a = abs(dir);
    const int axis = a.x >= a.y && a.x >= a.z ? 0 : (a.y >= a.z ? 1 : 2);
    n[axis] = dir[axis] > 0.0f ? -1 : 1;
    return n;
  }
  const int axis = abs(code) - 1;
  n[axis] = code > 0 ? 1 : -1;
  return n;
}

#endif

// CPU reference of the procedural appearance renderer; see appearance_cpu.h.
#include "render/appearance/appearance_cpu.h"

#include "render/appearance/shading_cpu.h"
#include "render/raycast_cpu.h"

#include <algorithm>
#include <cmath>
#include <thread>

namespace icube::render {

AppearanceImage render_appearance_cpu(const world::VoxelGrid& grid, const Camera& cam,
                                      const shader::AppearanceParams& lighting, const std::vector<WorldLight>& lights,
                                      const AppearanceOptions& o, unsigned threads) {
  validate_camera(cam);
  RaycastOptions ro;
  ro.pixels = o.pixels;
  const std::vector<RayResult> hits = cast_camera_cpu(grid, cam, ro, threads);
  const glm::dvec3 origin = grid.origin();
  const double vs = grid.voxel_size();
  const glm::dvec3 cam_pos = camera_position(cam);
  const glm::ivec3 ref(glm::floor((cam_pos - origin) / vs));
  const glm::dvec3 corner = origin + glm::dvec3(ref) * vs;
  const std::vector<shader::AppearanceLight> fl = lights_for_frame(lights, origin, vs, ref, cam_pos);
  shading::Shader S;
  S.P = lighting;
  S.P.flags &= APPEARANCE_FLAG_SUN;
  if (o.shadows && (S.P.flags & APPEARANCE_FLAG_SUN)) S.P.flags |= APPEARANCE_FLAG_SHADOWS;
  if (o.ambient_occlusion) S.P.flags |= APPEARANCE_FLAG_AO;
  S.P.voxel_size = static_cast<float>(vs);
  S.P.light_count = static_cast<uint32_t>(fl.size());
  const glm::vec3 sun(S.P.sun_x, S.P.sun_y, S.P.sun_z);
  const world::IjkBounds bounds = raycast_bounds(grid);
  RaycastOptions so;
  so.t_max = o.shadow_t_max;

  AppearanceImage img;
  img.width = cam.K.width;
  img.height = cam.K.height;
  const size_t n = size_t{img.width} * img.height;
  img.rgba.assign(n, 0u);
  img.labels.assign(n, 0u);
  auto pixel = [&](size_t i) {
    const uint32_t u = static_cast<uint32_t>(i % img.width), v = static_cast<uint32_t>(i / img.width);
    const Ray ray = camera_ray(cam, u, v, o.pixels);
    const glm::vec3 d(ray.dir);
    const RayResult& h = hits[i];
    if (!h.sem_hit) {
      img.rgba[i] = S.shade_encode(S.shade_sky_pixel(d), 0u);
      return;
    }
    const glm::ivec3 nf = S.shade_face_normal(h.normal, d);
    const glm::dvec3 hit = ray.origin + ray.dir * h.t_sem;
    const glm::vec3 local = glm::clamp(glm::vec3((hit - origin) / vs - glm::dvec3(h.ijk)), 0.0f, 1.0f);
    const shading::Shader::ShadeMaterial m = S.shade_material(h.class_id, h.instance, h.ijk, local, nf);
    float sun_vis = 1.0f;
    if ((S.P.flags & APPEARANCE_FLAG_SHADOWS) && glm::dot(glm::vec3(nf), sun) > 0.0f) {
      Ray sr;
      sr.origin = hit + glm::dvec3(nf) * (0.02 * vs);
      sr.dir = glm::dvec3(sun);
      sun_vis = cast_ray_cpu(grid, bounds, sr, so).sem_hit ? 0.0f : 1.0f;
    }
    float ao = 1.0f;
    if (S.P.flags & APPEARANCE_FLAG_AO) {
      float occluded = 0.0f;
      for (int k = 0; k < shading::Shader::kShadeAoProbes; ++k)
        if (grid.get(S.shade_ao_probe(k, h.ijk, nf)).class_id != 0) occluded += S.shade_ao_weight(k);
      ao = S.shade_ao(occluded);
    }
    const glm::vec3 pos(hit - corner);
    const glm::vec3 nrm(nf);
    glm::vec3 lit(0.0f);
    for (const shader::AppearanceLight& L : fl)
      lit += S.shade_light(glm::vec3(L.px, L.py, L.pz), L.range, glm::vec3(L.dx, L.dy, L.dz), L.cos_cut,
                           glm::vec3(L.r, L.g, L.b), L.kind, pos, nrm);
    const glm::vec3 col = S.shade_surface(m, nrm, -d, sun_vis, ao, lit);
    img.rgba[i] = S.shade_encode(S.shade_fog(col, static_cast<float>(h.t_sem)), 255u);
    img.labels[i] = (uint32_t{h.class_id} << 16) | h.instance;
  };
  const unsigned nt = std::max(1u, threads);
  std::vector<std::thread> pool;
  for (unsigned t = 0; t < nt; ++t)
    pool.emplace_back([&, t] {
      for (size_t i = t; i < n; i += nt) pixel(i);
    });
  for (std::thread& th : pool) th.join();
  return img;
}

}  // namespace icube::render

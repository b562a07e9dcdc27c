// Dynamic objects in their object frames; see dynamic_lift.h.
#include "lift/dynamic_lift.h"

#include "lift/static_lift.h"
#include "scene/frames.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <tuple>

namespace icube::lift {

size_t DynamicLiftAccumulator::CellHash::operator()(const glm::ivec3& c) const {
  uint64_t h = static_cast<uint32_t>(c.x) * 0x9E3779B97F4A7C15ull;
  h ^= static_cast<uint32_t>(c.y) * 0xC2B2AE3D27D4EB4Full + (h << 6) + (h >> 2);
  h ^= static_cast<uint32_t>(c.z) * 0x165667B19E3779F9ull + (h << 6) + (h >> 2);
  return static_cast<size_t>(h ^ (h >> 31));
}

void DynamicLiftAccumulator::add(uint16_t id, const glm::dvec3& world_point, const glm::dmat4& world_to_object,
                                 uint8_t r, uint8_t g, uint8_t b) {
  const glm::dvec3 p = glm::dvec3(world_to_object * glm::dvec4(world_point, 1.0));
  const glm::ivec3 c(static_cast<int>(std::floor(p.x / o_.cell)), static_cast<int>(std::floor(p.y / o_.cell)),
                     static_cast<int>(std::floor(p.z / o_.cell)));
  ObjectCell& a = objects_[id][c];
  a.sum_r += r, a.sum_g += g, a.sum_b += b, ++a.count;
  a.sum_point += p;
  ++samples_;
}

size_t DynamicLiftAccumulator::add_frame(const render::Camera& cam, render::PixelConvention pixels,
                                         const std::vector<uint8_t>& rgb, const std::vector<uint16_t>& instance,
                                         const std::vector<shader::RaycastHit>& hits,
                                         const std::map<uint16_t, glm::dmat4>& world_to_object) {
  const size_t W = cam.K.width, H = cam.K.height, n = W * H;
  if (rgb.size() != 3 * n || instance.size() != n || hits.size() != n)
    throw std::invalid_argument("DynamicLiftAccumulator::add_frame: image sizes disagree with the camera");
  const size_t before = samples_;
  for (size_t v = 0; v < H; ++v)
    for (size_t u = 0; u < W; ++u) {
      const size_t i = v * W + u;
      const uint16_t id = instance[i];
      if (id < kDynamicInstanceMin || (hits[i].flags & RAYCAST_FLAG_SEM) == 0u || hits[i].sem_instance != id) continue;
      const auto it = world_to_object.find(id);
      if (it == world_to_object.end()) continue;
      const render::Ray ray = render::camera_ray(cam, uint32_t(u), uint32_t(v), pixels);
      add(id, ray.origin + double(hits[i].t_sem) * ray.dir, it->second, rgb[3 * i], rgb[3 * i + 1], rgb[3 * i + 2]);
    }
  return samples_ - before;
}

std::map<uint16_t, splat::GaussianCloud> DynamicLiftAccumulator::emit() const {
  std::map<uint16_t, splat::GaussianCloud> out;
  const float sigma = static_cast<float>(double(o_.sigma_cells) * o_.cell);
  for (const auto& [id, cells] : objects_) {
    if (cells.size() < o_.min_cells) continue;
    std::vector<std::pair<glm::ivec3, const ObjectCell*>> sorted;
    sorted.reserve(cells.size());
    for (const auto& [c, a] : cells) sorted.emplace_back(c, &a);
    std::sort(sorted.begin(), sorted.end(),
              [](const auto& x, const auto& y) { return std::tie(x.first.z, x.first.y, x.first.x) < std::tie(y.first.z, y.first.y, y.first.x); });
    splat::GaussianCloud& cloud = out[id];
    for (const auto& [c, a] : sorted) {
      const double n = double(a->count);
      const float dc[3] = {static_cast<float>((double(a->sum_r) / (255.0 * n) - 0.5) / splat::kShC0),
                           static_cast<float>((double(a->sum_g) / (255.0 * n) - 0.5) / splat::kShC0),
                           static_cast<float>((double(a->sum_b) / (255.0 * n) - 0.5) / splat::kShC0)};
      cloud.add(a->sum_point / n, glm::vec3(sigma), glm::vec4(1.0f, 0.0f, 0.0f, 0.0f), o_.opacity, dc);
    }
  }
  return out;
}

std::map<uint16_t, const scene::BoxState*> dynamic_vehicle_states(const scene::Scene& s, int time_index) {
  std::map<uint16_t, const scene::BoxState*> out;
  for (size_t i = 0; i < s.tracks.size(); ++i) {
    const scene::Track& t = s.tracks[i];
    if (t.type != scene::ObjectType::Vehicle || !t.dynamic || scene::is_ego_track(s, i)) continue;
    if (t.instance_id < kDynamicInstanceMin || t.instance_id > 0xFFFFu) continue;
    if (const scene::BoxState* b = scene::state_filled(t, time_index)) out[static_cast<uint16_t>(t.instance_id)] = b;
  }
  return out;
}

std::map<uint16_t, glm::dmat4> dynamic_object_poses(const scene::Scene& s, int time_index) {
  std::map<uint16_t, glm::dmat4> out;
  for (const auto& [id, b] : dynamic_vehicle_states(s, time_index)) out[id] = scene::box_to_world(*b);
  return out;
}

}  // namespace icube::lift

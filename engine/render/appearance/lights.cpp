// Street lamps and headlights; see lights.h.
#include "render/appearance/lights.h"

#include "world/semantics.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <utility>

namespace icube::render {

std::vector<WorldLight> street_lamps(const world::VoxelGrid& grid) {
  // Pole columns: (x, y) -> (lowest z, highest z).
  std::map<std::pair<int, int>, std::pair<int, int>> cols;
  const auto pole = static_cast<uint8_t>(world::SemanticClass::Pole);
  grid.for_each_voxel([&](const glm::ivec3& ijk, const world::Voxel& v) {
    if (v.class_id != pole) return;
    auto [it, fresh] = cols.try_emplace({ijk.x, ijk.y}, ijk.z, ijk.z);
    if (!fresh) {
      it->second.first = std::min(it->second.first, ijk.z);
      it->second.second = std::max(it->second.second, ijk.z);
    }
  });
  struct Col {
    int x, y, lo, hi;
  };
  std::vector<Col> order;
  for (const auto& [xy, z] : cols) order.push_back({xy.first, xy.second, z.first, z.second});
  std::sort(order.begin(), order.end(), [](const Col& a, const Col& b) {
    return a.hi - a.lo != b.hi - b.lo ? a.hi - a.lo > b.hi - b.lo : std::tie(a.x, a.y) < std::tie(b.x, b.y);
  });
  const double vs = grid.voxel_size();
  const int merge = std::max(1, static_cast<int>(std::lround(1.6 / vs)));
  const int min_height = static_cast<int>(std::lround(4.0 / vs));
  std::vector<Col> taken;
  std::vector<WorldLight> out;
  for (const Col& c : order) {
    if (c.hi - c.lo + 1 < min_height) break;
    bool near = false;
    for (const Col& t : taken) near = near || (std::abs(t.x - c.x) <= merge && std::abs(t.y - c.y) <= merge);
    if (near) continue;
    taken.push_back(c);
    WorldLight l;
    l.pos = grid.ijk_to_world({c.x, c.y, c.hi}) - glm::dvec3(0.0, 0.0, vs);
    l.range = 6.0;
    l.intensity = glm::vec3(0.65f, 0.55f, 0.40f);
    l.kind = APPEARANCE_LIGHT_LAMP;
    out.push_back(l);
  }
  return out;
}

std::vector<WorldLight> headlights(const scene::Scene& s, int time_index) {
  std::vector<WorldLight> out;
  if (time_index < 0) return out;
  for (size_t i = 0; i < s.tracks.size(); ++i) {
    const scene::Track& t = s.tracks[i];
    if (t.type != scene::ObjectType::Vehicle || !t.dynamic || scene::is_ego_track(s, i)) continue;
    const scene::BoxState* b = scene::state_filled(t, time_index);
    if (!b) continue;
    const glm::dvec3 fwd(std::cos(b->heading), std::sin(b->heading), 0.0);
    const glm::dvec3 left(-fwd.y, fwd.x, 0.0);
    const double down = 4.0 * 3.14159265358979323846 / 180.0;
    const glm::dvec3 aim = glm::normalize(fwd * std::cos(down) - glm::dvec3(0.0, 0.0, std::sin(down)));
    for (const double side : {-1.0, 1.0}) {
      WorldLight l;
      l.pos = b->center + fwd * (0.5 * b->length + 0.05) + left * (side * 0.35 * b->width) +
              glm::dvec3(0.0, 0.0, -0.5 * b->height + 0.65);
      l.dir = aim;
      l.cos_cut = std::cos(35.0 * 3.14159265358979323846 / 180.0);
      l.range = 10.0;
      l.intensity = glm::vec3(3.0f, 3.0f, 2.8f);
      l.kind = APPEARANCE_LIGHT_HEADLIGHT;
      out.push_back(l);
    }
  }
  return out;
}

std::vector<shader::AppearanceLight> lights_for_frame(const std::vector<WorldLight>& lights, const glm::dvec3& grid_origin,
                                                      double voxel_size, const glm::ivec3& ref,
                                                      const glm::dvec3& camera, size_t max_count,
                                                      double max_distance_m) {
  std::vector<std::pair<double, size_t>> near;
  for (size_t i = 0; i < lights.size(); ++i) {
    const double d = glm::length(lights[i].pos - camera);
    if (d <= max_distance_m) near.emplace_back(d, i);
  }
  std::sort(near.begin(), near.end());
  if (near.size() > max_count) near.resize(max_count);
  const glm::dvec3 corner = grid_origin + glm::dvec3(ref) * voxel_size;
  std::vector<shader::AppearanceLight> out;
  for (const auto& [d, i] : near) {
    const WorldLight& l = lights[i];
    const glm::dvec3 p = l.pos - corner;
    shader::AppearanceLight g{};
    g.px = static_cast<float>(p.x), g.py = static_cast<float>(p.y), g.pz = static_cast<float>(p.z);
    g.range = static_cast<float>(l.range);
    g.dx = static_cast<float>(l.dir.x), g.dy = static_cast<float>(l.dir.y), g.dz = static_cast<float>(l.dir.z);
    g.cos_cut = static_cast<float>(l.cos_cut);
    g.r = l.intensity.x, g.g = l.intensity.y, g.b = l.intensity.z;
    g.kind = l.kind;
    out.push_back(g);
  }
  return out;
}

}  // namespace icube::render

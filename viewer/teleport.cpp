// Teleport targets and placing the car; see teleport.h.
#include "teleport.h"

#include "world/semantics.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>

namespace icube::viewer {

namespace {

bool drivable(uint8_t c) { return c == 18 || c == 19; }                 // road, lane marking
bool ground_class(uint8_t c) { return c >= 17 && c <= 22; }              // curb .. sidewalk

glm::dvec3 centroid(const std::vector<glm::dvec3>& pts) {
  glm::dvec3 c(0.0);
  for (const glm::dvec3& p : pts) c += p;
  return pts.empty() ? c : c / static_cast<double>(pts.size());
}

// The point at half the arc length of a polyline and the direction of its segment there.
std::pair<glm::dvec3, std::optional<double>> polyline_middle(const std::vector<glm::dvec3>& pts) {
  if (pts.size() < 2) return {pts.empty() ? glm::dvec3(0.0) : pts[0], std::nullopt};
  double total = 0.0;
  for (size_t i = 1; i < pts.size(); ++i) total += glm::length(glm::dvec2(pts[i] - pts[i - 1]));
  double run = 0.0;
  for (size_t i = 1; i < pts.size(); ++i) {
    const glm::dvec3 seg = pts[i] - pts[i - 1];
    const double len = glm::length(glm::dvec2(seg));
    if (len > 0.0 && run + len >= 0.5 * total) {
      const double f = (0.5 * total - run) / len;
      return {pts[i - 1] + f * seg, std::atan2(seg.y, seg.x)};
    }
    run += len;
  }
  return {pts.back(), std::nullopt};
}

// The first voxel from the top of the column at (x, y) that is not passed through (vehicle.h's rule), its class.
std::optional<std::pair<double, uint8_t>> top_surface(const world::VoxelGrid& grid, double x, double y, int zmin,
                                                      int zmax) {
  const glm::ivec3 c = grid.world_to_ijk({x, y, 0.0});
  for (int z = zmax; z >= zmin; --z) {
    const uint8_t cls = grid.get({c.x, c.y, z}).class_id;
    if (cls >= 14) return std::make_pair(grid.origin().z + (z + 1) * grid.voxel_size(), cls);
  }
  return std::nullopt;
}

}  // namespace

const char* target_kind_name(TargetKind k) {
  switch (k) {
    case TargetKind::EgoStart: return "ego start";
    case TargetKind::Lane: return "lane";
    case TargetKind::Crosswalk: return "crosswalk";
    case TargetKind::StopSign: return "stop sign";
    case TargetKind::SpeedBump: return "speed bump";
    case TargetKind::Driveway: return "driveway";
    case TargetKind::Chunk: return "chunk";
  }
  return "?";
}

std::vector<TeleportTarget> map_targets(const scene::Scene& s) {
  std::vector<TeleportTarget> out;
  for (const scene::EgoPose& e : s.ego)
    if (e.valid) {
      const VehicleState v = vehicle_from_ego(e.ego_to_world);
      out.push_back({TargetKind::EgoStart, "ego track start", v.position, v.yaw});
      break;
    }
  for (const scene::Lane& l : s.map.lanes) {
    if (l.points.empty()) continue;
    const auto [p, yaw] = polyline_middle(l.points);
    out.push_back({TargetKind::Lane, "lane " + std::to_string(l.id) + " (" + scene::lane_type_name(l.type) + ")", p, yaw});
  }
  auto polygons = [&](const std::vector<scene::Polygon>& v, TargetKind k) {
    for (const scene::Polygon& g : v)
      if (!g.points.empty())
        out.push_back({k, std::string(target_kind_name(k)) + " " + std::to_string(g.id), centroid(g.points),
                       nearest_lane_heading(s, glm::dvec2(centroid(g.points)), 15.0)});
  };
  polygons(s.map.crosswalks, TargetKind::Crosswalk);
  for (const scene::StopSign& st : s.map.stop_signs) {
    // Face along the sign's own lane where it lists one (nearest segment of that lane), else the nearest lane.
    std::optional<double> yaw;
    for (const scene::Lane& l : s.map.lanes)
      if (!st.lanes.empty() && l.id == st.lanes[0]) {
        scene::Scene one;
        one.map.lanes.push_back(l);
        yaw = nearest_lane_heading(one, glm::dvec2(st.position), 1e9);
      }
    if (!yaw) yaw = nearest_lane_heading(s, glm::dvec2(st.position), 15.0);
    out.push_back({TargetKind::StopSign, "stop sign " + std::to_string(st.id), st.position, yaw});
  }
  polygons(s.map.speed_bumps, TargetKind::SpeedBump);
  polygons(s.map.driveways, TargetKind::Driveway);
  return out;
}

std::vector<TeleportTarget> chunk_targets(const world::VoxelGrid& grid, double tile_m) {
  std::map<std::pair<int64_t, int64_t>, double> tiles;  // (j, i) -> highest ground top seen
  const double vs = grid.voxel_size();
  grid.for_each_voxel([&](const glm::ivec3& ijk, const world::Voxel& v) {
    if (!ground_class(v.class_id)) return;
    const glm::dvec3 w = grid.origin() + (glm::dvec3(ijk) + 0.5) * vs;
    const auto key = std::make_pair(static_cast<int64_t>(std::floor(w.y / tile_m)), static_cast<int64_t>(std::floor(w.x / tile_m)));
    auto [it, fresh] = tiles.emplace(key, w.z);
    if (!fresh) it->second = std::max(it->second, w.z);
  });
  std::vector<TeleportTarget> out;
  const world::IjkBounds b = grid.bounds();
  const double top = grid.origin().z + (b.max.z + 1) * vs;
  for (const auto& [key, z] : tiles) {
    TeleportTarget t;
    t.kind = TargetKind::Chunk;
    t.label = "chunk (" + std::to_string(key.second) + ", " + std::to_string(key.first) + ")";
    t.position = {(static_cast<double>(key.second) + 0.5) * tile_m, (static_cast<double>(key.first) + 0.5) * tile_m, top};
    out.push_back(t);
  }
  return out;
}

std::optional<double> nearest_lane_heading(const scene::Scene& s, const glm::dvec2& xy, double max_dist) {
  double best = max_dist;
  std::optional<double> yaw;
  for (const scene::Lane& l : s.map.lanes)
    for (size_t i = 1; i < l.points.size(); ++i) {
      const glm::dvec2 a(l.points[i - 1]), b(l.points[i]);
      const glm::dvec2 ab = b - a;
      const double len2 = glm::dot(ab, ab);
      if (!(len2 > 0.0)) continue;
      const double f = std::clamp(glm::dot(xy - a, ab) / len2, 0.0, 1.0);
      const double d = glm::length(xy - (a + f * ab));
      if (d < best) {
        best = d;
        yaw = std::atan2(ab.y, ab.x);
      }
    }
  return yaw;
}

bool place_at_target(VehicleState& car, const TeleportTarget& t, const world::VoxelGrid& grid,
                     const VehicleLimits& lim, const GroundOptions& ground, const scene::Scene* s,
                     const PlaceOptions& opts) {
  VehicleState next = car;
  next.speed = 0.0;
  next.steer = 0.0;
  next.reversing = false;
  next.position = t.position;
  double search_from = t.position.z + opts.above;
  if (t.kind == TargetKind::Chunk) {
    // The nearest column (rings of 1 m around the centre) whose top surface is road, else other ground.
    const world::IjkBounds b = grid.bounds();
    std::optional<glm::dvec2> road, other;
    for (double r = 0.0; r <= opts.search_radius && !road; r += 1.0) {
      const int n = r == 0.0 ? 1 : static_cast<int>(std::ceil(2.0 * 3.14159265358979 * r));
      for (int k = 0; k < n && !road; ++k) {
        const double a = 2.0 * 3.14159265358979 * k / n;
        const glm::dvec2 q = glm::dvec2(t.position) + r * glm::dvec2(std::cos(a), std::sin(a));
        const auto top = top_surface(grid, q.x, q.y, b.min.z, b.max.z);
        if (!top) continue;
        if (drivable(top->second)) road = q;
        else if (!other && ground_class(top->second)) other = q;
      }
    }
    if (!road && !other) return false;
    next.position = glm::dvec3(road ? *road : *other, t.position.z);
    search_from = t.position.z + grid.voxel_size();
  }
  if (t.yaw) next.yaw = *t.yaw;
  else if (s) {
    if (const auto y = nearest_lane_heading(*s, glm::dvec2(next.position), opts.lane_radius)) next.yaw = *y;
  }
  if (!settle_vehicle(next, lim, grid, ground, search_from)) return false;
  car = next;
  return true;
}

}  // namespace icube::viewer

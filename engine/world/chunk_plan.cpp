// Chunk planning: trajectory keys along the ego drive and the blocks lattice
// over the road (see chunk_plan.h for the rules), and the plan as JSON.
#include "world/chunk_plan.h"

#include "scene/frames.h"
#include "scene/input_error.h"

#include <glm/gtc/quaternion.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <stdexcept>
#include <utility>

namespace icube::world {

namespace {

std::string source_name(const scene::Scene& s) {
  return s.provenance.source_file.empty() ? std::string("scene") : s.provenance.source_file;
}

void check_options(const PlanOptions& o) {
  if (!std::isfinite(o.stride_m) || o.stride_m <= 0.0)
    throw std::invalid_argument("plan: stride must be a finite number of metres > 0");
  if (o.extrapolate_chunks < 0 || o.extrapolate_chunks > 10000)
    throw std::invalid_argument("plan: extrapolate_chunks must be in 0 to 10000");
  if (!std::isfinite(o.default_camera_height_m))
    throw std::invalid_argument("plan: default camera height must be finite");
  if (!std::isfinite(o.parked_travel_m) || o.parked_travel_m < 0.0)
    throw std::invalid_argument("plan: parked travel must be a finite number of metres >= 0");
  if (o.max_chunks < 0) throw std::invalid_argument("plan: max_chunks must be >= 0 (0 = all)");
}

bool finite_matrix(const glm::dmat4& m) {
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r)
      if (!std::isfinite(m[c][r])) return false;
  return true;
}

// The chunk pose keyed on a camera (FLU camera-to-world).
ChunkPose chunk_from_camera(const glm::dmat4& cam, int32_t index) {
  ChunkPose c;
  c.index = index;
  c.chunk_to_world = cam;
  const glm::dvec3 up = glm::dvec3(cam[2]);
  c.chunk_to_world[3] = glm::dvec4(glm::dvec3(cam[3]) + kChunkUpOffset * up, 1.0);
  c.key_camera_world = glm::dvec3(cam[3]);
  return c;
}

// Ego pose between poses a and b at fraction t: position lerp, rotation slerp.
glm::dmat4 interpolate_pose(const glm::dmat4& a, const glm::dmat4& b, double t) {
  if (t <= 0.0) return a;
  if (t >= 1.0) return b;
  const glm::dquat qa = glm::quat_cast(glm::dmat3(a)), qb = glm::quat_cast(glm::dmat3(b));
  glm::dmat4 m(glm::mat3_cast(glm::slerp(qa, qb, t)));
  const glm::dvec3 pa(a[3]), pb(b[3]);
  m[3] = glm::dvec4(pa + (pb - pa) * t, 1.0);
  return m;
}

}  // namespace

const char* plan_mode_name(PlanMode m) { return m == PlanMode::Blocks ? "blocks" : "trajectory"; }

const char* chunk_kind_name(ChunkKind k) {
  switch (k) {
    case ChunkKind::Key: return "key";
    case ChunkKind::Extrapolated: return "extrapolated";
    case ChunkKind::Block: return "block";
  }
  return "?";
}

glm::dvec3 chunk_centre(const ChunkPose& c) { return glm::dvec3(c.chunk_to_world[3]); }

double chunk_heading(const ChunkPose& c) { return std::atan2(c.chunk_to_world[0].y, c.chunk_to_world[0].x); }

std::vector<glm::dvec2> chunk_footprint(const ChunkPose& c) {
  const double h = kChunkHalfExtent.x;
  std::vector<glm::dvec2> out;
  for (const glm::dvec2 q : {glm::dvec2(h, -h), glm::dvec2(h, h), glm::dvec2(-h, h), glm::dvec2(-h, -h)})
    out.emplace_back(c.chunk_to_world * glm::dvec4(q, 0.0, 1.0));
  return out;
}

// ---- trajectory mode ----------------------------------------------------------------

ChunkPlan plan_trajectory(const scene::Scene& scene, const PlanOptions& o) {
  check_options(o);
  const std::string file = source_name(scene);
  std::vector<size_t> valid;
  for (size_t i = 0; i < scene.ego.size(); ++i) {
    if (!scene.ego[i].valid) continue;
    if (!finite_matrix(scene.ego[i].ego_to_world))
      throw scene::InputError(file, "ego[" + std::to_string(i) + "].ego_to_world", "is not finite");
    valid.push_back(i);
  }
  if (valid.size() < 2)
    throw scene::InputError(file, "",
                            "trajectory mode needs an ego trajectory with at least 2 valid poses (the scene has " +
                                std::to_string(valid.size()) +
                                "); make one with `icube scene route` or use --mode blocks");

  // The key camera: first camera, else the ego raised along its up axis.
  glm::dmat4 cam_to_ego(1.0);
  if (!scene.cameras.empty()) {
    cam_to_ego = scene.cameras[0].camera_to_ego;
    if (!finite_matrix(cam_to_ego)) throw scene::InputError(file, "cameras[0].camera_to_ego", "is not finite");
  } else {
    cam_to_ego[3] = glm::dvec4(0.0, 0.0, o.default_camera_height_m, 1.0);
  }
  auto pose = [&](size_t k) { return scene.ego[valid[k]].ego_to_world; };
  auto position = [&](size_t k) { return glm::dvec3(pose(k)[3]); };

  std::vector<double> arc(valid.size(), 0.0);
  for (size_t k = 1; k < valid.size(); ++k) arc[k] = arc[k - 1] + glm::length(position(k) - position(k - 1));

  ChunkPlan plan;
  plan.mode = PlanMode::Trajectory;
  plan.stride_m = o.stride_m;
  plan.path_length_m = arc.back();
  auto add = [&](const glm::dmat4& ego, ChunkKind kind, double s, int time_index) {
    scene::EgoPose at;
    at.ego_to_world = ego;
    const glm::dmat4 cam = scene.cameras.empty() ? ego * cam_to_ego : scene::camera_to_world_flu(at, scene.cameras[0]);
    plan.chunks.push_back(chunk_from_camera(cam, static_cast<int32_t>(plan.chunks.size())));
    ChunkInfo info;
    info.kind = kind;
    info.arc_length_m = s;
    info.ego_position = glm::dvec3(ego[3]);
    info.time_index = time_index;
    plan.info.push_back(info);
  };

  if (plan.path_length_m < o.parked_travel_m) {
    plan.parked = true;
    add(pose(0), ChunkKind::Key, 0.0, static_cast<int>(valid[0]));
    char buf[160];
    std::snprintf(buf, sizeof buf, "the ego is parked (travels %.3g m): one chunk at its first pose, no extrapolation",
                  plan.path_length_m);
    plan.notes.push_back(buf);
    return plan;
  }

  // Keys at s = k * stride on the path.
  const double L = plan.path_length_m;
  size_t seg = 0;
  int64_t k = 0;
  for (;; ++k) {
    const double s = static_cast<double>(k) * o.stride_m;
    if (s > L * (1.0 + 1e-12)) break;
    while (seg + 2 < valid.size() && arc[seg + 1] < s) ++seg;
    const double d = arc[seg + 1] - arc[seg];
    const double t = d > 0.0 ? std::clamp((s - arc[seg]) / d, 0.0, 1.0) : 0.0;
    const size_t at = t >= 1.0 ? seg + 1 : seg;
    add(interpolate_pose(pose(seg), pose(seg + 1), t), ChunkKind::Key, s, static_cast<int>(valid[at]));
  }

  // Extrapolated keys: continue straight along the last pose's forward axis.
  const glm::dmat4 last = pose(valid.size() - 1);
  const glm::dvec3 fwd = glm::normalize(glm::dvec3(last[0]));
  for (int j = 0; j < o.extrapolate_chunks; ++j, ++k) {
    const double s = static_cast<double>(k) * o.stride_m;
    glm::dmat4 m = last;
    m[3] = glm::dvec4(glm::dvec3(last[3]) + (s - L) * fwd, 1.0);
    add(m, ChunkKind::Extrapolated, s, -1);
  }
  return plan;
}

// ---- blocks mode -------------------------------------------------------------------

namespace {

struct BlockAccum {
  size_t edge = 0, surface = 0;
  std::vector<double> z;
};

double median(std::vector<double>& v) {
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

// Lattice indices i >= 0 whose footprint [i*S, i*S + 2*half) holds offset u (>= 0).
std::pair<int64_t, int64_t> index_range(double u, double stride, double half) {
  const int64_t hi = static_cast<int64_t>(std::floor(u / stride));
  int64_t lo = static_cast<int64_t>(std::floor((u - 2.0 * half) / stride)) + 1;
  lo = std::max<int64_t>(lo, 0);
  while (lo > 0 && u < static_cast<double>(lo - 1) * stride + 2.0 * half) --lo;  // rounding guard
  while (lo <= hi && !(u < static_cast<double>(lo) * stride + 2.0 * half)) ++lo;
  return {lo, hi};
}

}  // namespace

ChunkPlan plan_blocks(const scene::Scene& scene, const PlanOptions& o) {
  check_options(o);
  return plan_blocks(scene, build_road_surface(scene.map), o);
}

ChunkPlan plan_blocks(const scene::Scene& scene, const RoadSurface& surface, const PlanOptions& o) {
  check_options(o);
  const std::string file = source_name(scene);
  const scene::Map& map = scene.map;
  enum Layer { Edge, Line, Lane };
  glm::dvec2 lo(std::numeric_limits<double>::infinity());
  size_t edges = 0, lanes = 0;
  auto scan = [&](const auto& features, const char* name, size_t& count) {
    for (size_t f = 0; f < features.size(); ++f)
      for (size_t p = 0; p < features[f].points.size(); ++p) {
        const glm::dvec3& q = features[f].points[p];
        if (!std::isfinite(q.x) || !std::isfinite(q.y) || !std::isfinite(q.z))
          throw scene::InputError(file, std::string("map.") + name + "[" + std::to_string(f) + "].points[" +
                                            std::to_string(p) + "]",
                                  "coordinate is not finite");
        lo = glm::min(lo, glm::dvec2(q));
        ++count;
      }
  };
  size_t lines = 0;
  scan(map.road_edges, "road_edges", edges);
  scan(map.road_lines, "road_lines", lines);
  scan(map.lanes, "lanes", lanes);
  if (edges == 0 || lanes == 0)
    throw scene::InputError(file, "",
                            "blocks mode needs road edges and lane centre lines (the map has " +
                                std::to_string(edges) + " road-edge and " + std::to_string(lanes) + " lane points)");

  const double S = o.stride_m, half = kChunkHalfExtent.x;
  std::map<std::pair<int64_t, int64_t>, BlockAccum> blocks;
  // Every block whose footprint holds q (blocks left of or below the anchor do not exist).
  auto each_block = [&](const glm::dvec3& q, auto&& visit) {
    if (!(q.x >= lo.x && q.y >= lo.y)) return;  // road-surface points outside the anchored lattice
    const auto [i0, i1] = index_range(q.x - lo.x, S, half);
    const auto [j0, j1] = index_range(q.y - lo.y, S, half);
    for (int64_t i = i0; i <= i1; ++i)
      for (int64_t j = j0; j <= j1; ++j) visit(blocks[{i, j}]);
  };
  // Road height: the z of the edge, line and lane-centre points.
  auto bin = [&](const auto& features, Layer layer) {
    for (const auto& f : features)
      for (const glm::dvec3& q : f.points)
        each_block(q, [&](BlockAccum& b) {
          if (layer == Edge) ++b.edge;
          b.z.push_back(q.z);
        });
  };
  bin(map.road_edges, Edge);
  bin(map.road_lines, Line);
  bin(map.lanes, Lane);
  for (const glm::dvec3& q : surface.points()) each_block(q, [](BlockAccum& b) { ++b.surface; });

  ChunkPlan plan;
  plan.mode = PlanMode::Blocks;
  plan.stride_m = S;
  plan.lattice_anchor = lo;
  size_t dropped = 0;
  for (auto& [ij, b] : blocks) {  // std::map order: x outer, y inner
    if (b.edge == 0 || b.surface == 0 || b.z.empty()) {
      ++dropped;
      continue;
    }
    const double road_z = median(b.z);
    ChunkPose c;
    c.index = static_cast<int32_t>(plan.chunks.size());
    const glm::dvec3 centre(lo.x + (static_cast<double>(ij.first) * S + half),
                            lo.y + (static_cast<double>(ij.second) * S + half),
                            road_z + o.default_camera_height_m + kChunkUpOffset);
    c.chunk_to_world[3] = glm::dvec4(centre, 1.0);
    c.key_camera_world = centre - glm::dvec3(0.0, 0.0, kChunkUpOffset);
    plan.chunks.push_back(c);
    ChunkInfo info;
    info.kind = ChunkKind::Block;
    info.ego_position = glm::dvec3(centre.x, centre.y, road_z);
    info.lattice_i = static_cast<int>(ij.first);
    info.lattice_j = static_cast<int>(ij.second);
    info.edge_points = b.edge;
    info.surface_points = b.surface;
    plan.info.push_back(info);
  }
  if (dropped > 0)
    plan.notes.push_back(std::to_string(dropped) + " block(s) with map points but without both road-edge and "
                         "road-surface points were left out");
  return plan;
}

ChunkPlan plan_chunks(const scene::Scene& scene, PlanMode mode, const PlanOptions& options) {
  ChunkPlan plan = mode == PlanMode::Blocks ? plan_blocks(scene, options) : plan_trajectory(scene, options);
  const size_t limit = static_cast<size_t>(options.max_chunks);
  if (limit > 0 && plan.chunks.size() > limit) {
    plan.notes.push_back("only the first " + std::to_string(limit) + " of " + std::to_string(plan.chunks.size()) +
                         " chunks are planned (--max-chunks)");
    plan.chunks.resize(limit);
    plan.info.resize(limit);
  }
  return plan;
}

// ---- JSON ----------------------------------------------------------------------------

std::string plan_to_json(const ChunkPlan& plan) {
  using Json = nlohmann::ordered_json;
  auto vec = [](const glm::dvec3& v) { return Json::array({v.x, v.y, v.z}); };
  Json chunks = Json::array();
  for (size_t n = 0; n < plan.chunks.size(); ++n) {
    const ChunkPose& c = plan.chunks[n];
    const ChunkInfo& info = plan.info[n];
    Json rows = Json::array();
    for (int r = 0; r < 4; ++r)
      rows.push_back(Json::array({c.chunk_to_world[0][r], c.chunk_to_world[1][r], c.chunk_to_world[2][r],
                                  c.chunk_to_world[3][r]}));
    Json j = {{"index", c.index},
              {"kind", chunk_kind_name(info.kind)},
              {"centre", vec(chunk_centre(c))},
              {"heading", chunk_heading(c)},
              {"key_camera_world", vec(c.key_camera_world)},
              {"chunk_to_world", std::move(rows)}};
    if (plan.mode == PlanMode::Trajectory) {
      j["arc_length_m"] = info.arc_length_m;
      j["time_index"] = info.time_index;
    } else {
      j["lattice_ij"] = Json::array({info.lattice_i, info.lattice_j});
      j["road_z"] = info.ego_position.z;
    }
    chunks.push_back(std::move(j));
  }
  Json doc = {{"format", "icube-chunk-plan"},
              {"version", 1},
              {"mode", plan_mode_name(plan.mode)},
              {"stride_m", plan.stride_m},
              {"chunk_half_extent_m", vec(kChunkHalfExtent)},
              {"chunk_up_offset_m", kChunkUpOffset}};
  if (plan.mode == PlanMode::Trajectory) {
    doc["path_length_m"] = plan.path_length_m;
    doc["parked"] = plan.parked;
  } else {
    doc["lattice_anchor"] = Json::array({plan.lattice_anchor.x, plan.lattice_anchor.y});
  }
  doc["chunks"] = std::move(chunks);
  return doc.dump(2) + "\n";
}

}  // namespace icube::world

// Stage-1 condition volume, CPU reference, and the gathering of its inputs
// (map points, road-surface points, static boxes) in the chunk frame; see conditions.h.
#include "world/conditions.h"

#include "scene/frames.h"
#include "world/polyline_resample.h"

#include <cmath>

namespace icube::world {

namespace {

struct Best {
  int box = -1;
  double intersection = 0.0;
};

bool overlaps(const AxisBox& a, const AxisBox& b) {
  return a.lo.x < b.hi.x && b.lo.x < a.hi.x && a.lo.y < b.hi.y && b.lo.y < a.hi.y && a.lo.z < b.hi.z &&
         b.lo.z < a.hi.z;
}

Best best_box(const ConditionInputs& in, const std::vector<AxisBox>& bounds, const AxisBox& cell) {
  Best best;
  double best_iou = 0.0;
  for (size_t b = 0; b < in.boxes.size(); ++b) {
    if (!overlaps(bounds[b], cell)) continue;
    const BoxCellOverlap o = box_cell_overlap(in.boxes[b].box, cell);
    if (o.iou > best_iou) {
      best_iou = o.iou;
      best = {static_cast<int>(b), o.intersection};
    }
  }
  return best;
}

bool is_static(const scene::Track& t) {
  if (t.instance_id != 0) return !t.dynamic;  // classify_tracks() already ran
  const scene::BoxState* prev = nullptr;
  for (const scene::BoxState& s : t.states) {
    if (!s.valid) continue;
    if (prev && glm::length(s.center - prev->center) > scene::kMovingThresholdMetres) return false;
    prev = &s;
  }
  return true;
}

}  // namespace

void append_grid_points(std::vector<glm::vec3>& out, const std::vector<glm::dvec3>& world_points,
                        const glm::dmat4& world_to_chunk) {
  for (const glm::dvec3& p : world_points) {
    const glm::dvec3 c = glm::dvec3(world_to_chunk * glm::dvec4(p, 1.0));
    const glm::dvec3 q = c / kLatentVoxel - 0.5 + static_cast<double>(kLatentDim / 2);
    bool keep = true;
    for (int k = 0; k < 3; ++k) keep = keep && q[k] >= -1.0 && q[k] <= kLatentDim + 1.0;  // also drops NaN
    if (keep) out.emplace_back(static_cast<float>(q.x), static_cast<float>(q.y), static_cast<float>(q.z));
  }
}

std::vector<ChunkBox> chunk_boxes(const scene::Scene& scene, const ChunkPose& pose, const ConditionOptions& opts) {
  std::vector<ChunkBox> out;
  const glm::dmat4 w2c = glm::inverse(pose.chunk_to_world);
  const glm::dmat3 r_w2c(w2c);
  const AxisBox chunk{-kChunkHalfExtent, kChunkHalfExtent};
  for (size_t t = 0; t < scene.tracks.size(); ++t) {
    const scene::Track& track = scene.tracks[t];
    if (static_cast<int>(t) == scene.sdc_track_index || track.type != scene::ObjectType::Vehicle) continue;
    if (opts.time_index < 0 || static_cast<size_t>(opts.time_index) >= track.states.size()) continue;
    const scene::BoxState& s = track.states[static_cast<size_t>(opts.time_index)];
    if (!s.valid || (!opts.include_dynamic && !is_static(track))) continue;
    ChunkBox cb;
    cb.box.center = glm::dvec3(w2c * glm::dvec4(s.center, 1.0));
    cb.box.axes = r_w2c * scene::box_rotation(s);
    cb.box.size = {s.length, s.width, s.height};
    // θ = atan2(c0.y − c3.y, c0.x − c3.x) in the chunk frame: c0 − c3 = length · axis x.
    const double theta = std::atan2(cb.box.axes[0].y, cb.box.axes[0].x);
    cb.sin_heading = std::sin(theta);
    cb.cos_heading = std::cos(theta);
    if (!overlaps(box_bounds(cb.box), chunk)) continue;
    out.push_back(cb);
  }
  return out;
}

ConditionInputs gather_condition_inputs(const scene::Scene& scene, const ChunkPose& pose, const RoadSurface& surface,
                                        const ConditionOptions& opts) {
  ConditionInputs in;
  const glm::dmat4 w2c = glm::inverse(pose.chunk_to_world);
  std::vector<glm::dvec3> pts;
  for (const scene::RoadEdge& e : scene.map.road_edges) append_resampled(pts, e.points, kMapResampleStep);
  append_grid_points(in.edge_grid, pts, w2c);
  pts.clear();
  for (const scene::RoadLine& l : scene.map.road_lines) append_resampled(pts, l.points, kMapResampleStep);
  append_grid_points(in.line_grid, pts, w2c);
  append_grid_points(in.surface_grid, surface.points(), w2c);
  in.boxes = chunk_boxes(scene, pose, opts);
  return in;
}

ConditionInputs gather_condition_inputs(const scene::Scene& scene, const ChunkPose& pose, const ConditionOptions& opts) {
  return gather_condition_inputs(scene, pose, build_road_surface(scene.map, opts.surface), opts);
}

AxisBox latent_cell(int x, int y, int z) {
  const glm::dvec3 ijk(x - kLatentDim / 2, y - kLatentDim / 2, z - kLatentDim / 2);
  return {ijk * kLatentVoxel, (ijk + 1.0) * kLatentVoxel};
}

std::vector<double> box_intersections_cpu(const ConditionInputs& in) {
  std::vector<double> out(kCondVoxels, 0.0);
  std::vector<AxisBox> bounds;
  for (const ChunkBox& b : in.boxes) bounds.push_back(box_bounds(b.box));
  for (int x = 0; x < kLatentDim; ++x)
    for (int y = 0; y < kLatentDim; ++y)
      for (int z = 0; z < kLatentDim; ++z)
        out[cond_index(0, x, y, z)] = best_box(in, bounds, latent_cell(x, y, z)).intersection;
  return out;
}

std::vector<float> build_conditions_cpu(const ConditionInputs& in) {
  std::vector<float> vol(kCondChannels * kCondVoxels, 0.0f);
  std::vector<AxisBox> bounds;
  for (const ChunkBox& b : in.boxes) bounds.push_back(box_bounds(b.box));
  for (int x = 0; x < kLatentDim; ++x)
    for (int y = 0; y < kLatentDim; ++y)
      for (int z = 0; z < kLatentDim; ++z) {
        vol[cond_index(kCondI, x, y, z)] = static_cast<float>(x - kLatentDim / 2);
        vol[cond_index(kCondJ, x, y, z)] = static_cast<float>(y - kLatentDim / 2);
        vol[cond_index(kCondK, x, y, z)] = static_cast<float>(z - kLatentDim / 2);
        if (in.boxes.empty()) continue;
        const Best best = best_box(in, bounds, latent_cell(x, y, z));
        if (best.box >= 0 && best.intersection > kBoxOccupancyFraction * kLatentCellVolume) {
          const ChunkBox& b = in.boxes[static_cast<size_t>(best.box)];
          vol[cond_index(kCondSin, x, y, z)] = static_cast<float>(b.sin_heading);
          vol[cond_index(kCondCos, x, y, z)] = static_cast<float>(b.cos_heading);
        }
      }
  const std::pair<const std::vector<glm::vec3>*, int> maps[] = {
      {&in.edge_grid, kCondRoadEdge}, {&in.line_grid, kCondRoadLine}, {&in.surface_grid, kCondRoadSurface}};
  for (const auto& [pts, channel] : maps)
    for (const glm::vec3& q : *pts) {
      const float rx = std::nearbyint(q.x), ry = std::nearbyint(q.y), rz = std::nearbyint(q.z);
      if (!(rx >= 0.0f && rx < kLatentDim && ry >= 0.0f && ry < kLatentDim && rz >= 0.0f && rz < kLatentDim)) continue;
      vol[cond_index(channel, static_cast<int>(rx), static_cast<int>(ry), static_cast<int>(rz))] = 1.0f;
    }
  return vol;
}

}  // namespace icube::world

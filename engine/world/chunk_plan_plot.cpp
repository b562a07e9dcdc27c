// Draws a chunk plan over the scene's map plot (see chunk_plan_plot.h).
#include "world/chunk_plan_plot.h"

#include "scene/raster.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>

namespace icube::world {

namespace {

// Distinct, bright on the dark map background.
constexpr std::array<scene::Rgba, 8> kPalette{{
    {255, 179, 0, 255},
    {0, 200, 255, 255},
    {255, 82, 160, 255},
    {120, 230, 90, 255},
    {180, 130, 255, 255},
    {255, 120, 60, 255},
    {70, 230, 210, 255},
    {250, 240, 110, 255},
}};

constexpr scene::Rgba kLabelHalo{8, 9, 12, 235};

}  // namespace

scene::Rgba chunk_colour(int32_t index) {
  const size_t n = kPalette.size();
  return kPalette[static_cast<size_t>(((index % static_cast<int32_t>(n)) + static_cast<int32_t>(n)) %
                                      static_cast<int32_t>(n))];
}

scene::MapPlot render_plan(const scene::Scene& scene, const ChunkPlan& plan, const PlanPlotOptions& o) {
  // The window: the map (and ego path) plus every footprint.
  double x0 = std::numeric_limits<double>::infinity(), y0 = x0, x1 = -x0, y1 = -x0;
  auto add = [&](double x, double y) {
    x0 = std::min(x0, x), y0 = std::min(y0, y), x1 = std::max(x1, x), y1 = std::max(y1, y);
  };
  auto add_all = [&](const auto& features) {
    for (const auto& f : features)
      for (const glm::dvec3& p : f.points) add(p.x, p.y);
  };
  const scene::Map& m = scene.map;
  add_all(m.road_edges), add_all(m.road_lines), add_all(m.lanes), add_all(m.crosswalks);
  add_all(m.driveways), add_all(m.speed_bumps);
  for (const scene::EgoPose& e : scene.ego)
    if (e.valid) add(e.ego_to_world[3].x, e.ego_to_world[3].y);
  for (const ChunkPose& c : plan.chunks)
    for (const glm::dvec2& q : chunk_footprint(c)) add(q.x, q.y);

  scene::MapPlotOptions mo;
  mo.width = o.width;
  mo.max_height = o.max_height;
  mo.margin_m = o.margin_m;
  if (x0 <= x1 && y0 <= y1 && std::isfinite(x0) && std::isfinite(x1) && std::isfinite(y0) && std::isfinite(y1))
    mo.bounds = scene::PlotBounds{x0 - o.margin_m, y0 - o.margin_m, x1 + o.margin_m, y1 + o.margin_m};
  scene::MapPlot plot = scene::render_map(scene, mo);
  scene::Canvas& c = plot.image;
  const scene::MapView& v = plot.view;
  const double s = v.pixels_per_metre;
  const int ts = std::max(1, static_cast<int>(std::lround(o.width / 800.0)));

  // Fills first (all chunks), then outlines, then labels, so no label is covered.
  for (const ChunkPose& ch : plan.chunks) {
    std::vector<glm::dvec2> ring;
    for (const glm::dvec2& q : chunk_footprint(ch)) ring.push_back(v.to_pixel(q.x, q.y));
    c.fill_polygon(ring, scene::with_opacity(chunk_colour(ch.index), 0.10));
  }
  const double outline_w = std::clamp(0.25 * s, 1.5, 3.0);
  for (const ChunkPose& ch : plan.chunks) {
    std::vector<glm::dvec2> ring;
    for (const glm::dvec2& q : chunk_footprint(ch)) ring.push_back(v.to_pixel(q.x, q.y));
    c.stroke_polyline(ring, outline_w, scene::with_opacity(chunk_colour(ch.index), 0.9), true);
  }
  if (plan.mode == PlanMode::Trajectory) {
    const double r = std::clamp(0.8 * s, 3.0, 7.0), arrow_m = 10.0;
    for (size_t n = 0; n < plan.chunks.size(); ++n) {
      const ChunkPose& ch = plan.chunks[n];
      const glm::dvec3 cam = ch.key_camera_world;
      const glm::dvec3 fwd = glm::dvec3(ch.chunk_to_world[0]);
      const glm::dvec2 a = v.to_pixel(cam.x, cam.y), b = v.to_pixel(cam.x + arrow_m * fwd.x, cam.y + arrow_m * fwd.y);
      const scene::Rgba col = chunk_colour(ch.index);
      c.stroke_polyline({a, b}, outline_w + 1.0, col);
      const glm::dvec2 d = glm::length(b - a) > 0.0 ? glm::normalize(b - a) : glm::dvec2(1.0, 0.0);
      const glm::dvec2 nrm(-d.y, d.x);
      const double hl = std::max(3.0 * r, 8.0);
      c.fill_polygon({b + d * (0.3 * hl), b - d * hl + nrm * (0.5 * hl), b - d * hl - nrm * (0.5 * hl)}, col);
      c.fill_circle(a, r + 1.5, kLabelHalo);
      c.fill_circle(a, r, plan.info[n].kind == ChunkKind::Extrapolated ? scene::Rgba{255, 255, 255, 255} : col);
    }
  }
  const int label_scale = ts + 1;
  for (const ChunkPose& ch : plan.chunks) {
    // Blocks: at the centre. Trajectory: the centre is right above the camera dot, so the
    // label goes 11.5 m to the chunk's left (inside the footprint, clear of the ego path).
    glm::dvec3 at = chunk_centre(ch);
    if (plan.mode == PlanMode::Trajectory) at += 11.5 * glm::dvec3(ch.chunk_to_world[1]);
    const glm::dvec2 p = v.to_pixel(at.x, at.y);
    const std::string label = std::to_string(ch.index);
    c.draw_text(static_cast<int>(std::lround(p.x - 0.5 * scene::text_width(label, label_scale))),
                static_cast<int>(std::lround(p.y - 0.5 * scene::text_height(label, label_scale))), label,
                chunk_colour(ch.index), label_scale, kLabelHalo);
  }

  // Caption at the map's bottom-left.
  char caption[160];
  std::snprintf(caption, sizeof caption, "%s plan: %zu chunk%s, 51.2 x 51.2 m footprints, stride %.1f m",
                plan_mode_name(plan.mode), plan.chunks.size(), plan.chunks.size() == 1 ? "" : "s", plan.stride_m);
  const int cap_x = v.map_x0 + 14, cap_y = v.map_y0 + v.map_height - 14 - scene::text_height(caption, ts);
  c.draw_text(cap_x, cap_y, caption, scene::Rgba{232, 234, 238, 255}, ts, kLabelHalo);
  return plot;
}

void write_plan_png(const scene::Scene& scene, const ChunkPlan& plan, const PlanPlotOptions& options,
                    const std::string& path) {
  scene::write_map_png(render_plan(scene, plan, options), path);
}

}  // namespace icube::world

// Top-down scene plots (engine/scene/map_plot.h): layout, where features and
// boxes land in pixels, the scale bar, the legend, errors, a 10 km map, and
// the real Waymo scenario and CARLA Town01 when ../shared/data is present.
#include <doctest/doctest.h>

#include "gpu_test_context.h"
#include "scene/map_plot.h"
#include "scene/scene_load.h"

#include "test_stb_image.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <string>

using namespace icube::scene;

namespace {

std::vector<glm::dvec3> line_pts(glm::dvec2 a, glm::dvec2 b, int n = 21) {
  std::vector<glm::dvec3> p;
  for (int i = 0; i < n; ++i) {
    const double t = static_cast<double>(i) / (n - 1);
    p.emplace_back(a.x + t * (b.x - a.x), a.y + t * (b.y - a.y), -185.0);
  }
  return p;
}

// A 100 m two-lane road along x with edges at y = 0 and y = 20, a double
// yellow centre line, a crosswalk, a stop sign and a driveway down to y = -8; a vehicle driving +x at
// 10 m/s, a parked one, and an ego that drives along the lower lane.
Scene synthetic_scene() {
  Scene s;
  s.provenance = {"synthetic.json", "icube-json", "road-100", ""};
  s.map.road_edges.push_back({1, RoadEdgeType::Boundary, line_pts({0, 0}, {100, 0})});
  s.map.road_edges.push_back({2, RoadEdgeType::Boundary, line_pts({0, 20}, {100, 20})});
  s.map.road_lines.push_back({3, RoadLineType::SolidDoubleYellow, "", line_pts({0, 10}, {100, 10})});
  s.map.lanes.push_back({4, LaneType::SurfaceStreet, 25.0, false, line_pts({0, 5}, {100, 5}), {}, {}, {}, {}});
  s.map.lanes.push_back({5, LaneType::SurfaceStreet, 25.0, false, line_pts({100, 15}, {0, 15}), {}, {}, {}, {}});
  s.map.crosswalks.push_back({6, {{80, 0, -185}, {84, 0, -185}, {84, 20, -185}, {80, 20, -185}}});
  s.map.stop_signs.push_back({7, {78, 2, -185}, {4}});
  s.map.driveways.push_back({8, {{40, -8, -185}, {46, -8, -185}, {46, 0, -185}, {40, 0, -185}}});
  for (int k = 0; k < 11; ++k) s.timestamps.push_back(k * 0.1);
  Track moving{10, ObjectType::Vehicle, {}, false, 0};
  Track parked{11, ObjectType::Vehicle, {}, false, 0};
  Track ego{12, ObjectType::Vehicle, {}, false, 0};
  for (int k = 0; k < 11; ++k) {
    BoxState b;
    b.center = {20.0 + k * 1.0, 15.0, -184.0};
    b.length = 4.5, b.width = 2.0, b.height = 1.6, b.heading = 0.0, b.valid = true;
    moving.states.push_back(b);
    b.center = {60.0, 17.5, -184.0};
    parked.states.push_back(b);
    b.center = {10.0 + k * 0.5, 5.0, -184.0};
    ego.states.push_back(b);
    EgoPose p;
    p.ego_to_world[3] = glm::dvec4(b.center, 1.0);
    s.ego.push_back(p);
  }
  s.tracks = {moving, parked, ego};
  s.sdc_track_index = 2;
  classify_tracks(s);
  return s;
}

bool near(Rgba a, Rgba b, int tol) {
  return std::abs(a.r - b.r) <= tol && std::abs(a.g - b.g) <= tol && std::abs(a.b - b.b) <= tol;
}

Rgba at(const MapPlot& p, glm::dvec2 px) { return p.image.pixel(static_cast<int>(px.x), static_cast<int>(px.y)); }

// Share of map-area pixels that differ from the background.
double drawn_fraction(const MapPlot& p) {
  size_t drawn = 0, total = 0;
  for (int y = p.view.map_y0; y < p.view.map_y0 + p.view.map_height; ++y)
    for (int x = 0; x < p.image.width(); ++x, ++total) drawn += !(p.image.pixel(x, y) == kPlotBackground);
  return static_cast<double>(drawn) / static_cast<double>(total);
}

}  // namespace

TEST_CASE("map plot: image size follows the width and the extent's aspect") {
  MapPlotOptions o;
  o.width = 800;
  const MapPlot p = render_map(synthetic_scene(), o);
  CHECK(p.image.width() == 800);
  CHECK(p.view.map_width == 800);
  // Extent 100 x 28 m + 10 m margin each side = 120 x 48 m across 800 - 2·12 px.
  CHECK(p.view.pixels_per_metre == doctest::Approx(776.0 / 120.0));
  CHECK(p.view.map_height == static_cast<int>(std::ceil(48.0 * 776.0 / 120.0)) + 24);
  CHECK(p.image.height() > p.view.map_y0 + p.view.map_height);  // title above, legend below
  CHECK(p.image.height() <= o.max_height);
  // The world centre lands in the middle of the map area.
  const glm::dvec2 c = p.view.to_pixel(50.0, 6.0);
  CHECK(c.x == doctest::Approx(400.0));
  CHECK(c.y == doctest::Approx(p.view.map_y0 + p.view.map_height / 2.0));
}

TEST_CASE("map plot: road-edge colour lies along a known edge") {
  const MapPlot p = render_map(synthetic_scene(), {});
  const Rgba edge = road_edge_colour(RoadEdgeType::Boundary);
  int hits = 0;
  for (double x = 5.0; x <= 95.0; x += 5.0) hits += near(at(p, p.view.to_pixel(x, 0.0)), edge, 16);
  CHECK(hits == 19);  // the whole edge, corners included (no overlay covers the map)
  // Halfway between the edge and the lane centre there is road surface, not edge.
  CHECK_FALSE(near(at(p, p.view.to_pixel(40.0, 2.5)), edge, 40));
}

TEST_CASE("map plot: boxes appear at their pixel position at the chosen time") {
  const Scene s = synthetic_scene();
  const Rgba car = object_colour(ObjectType::Vehicle);
  MapPlotOptions o;
  o.time_index = 0;
  MapPlot p0 = render_map(s, o);
  // Moving car at (20, 15) at t = 0: sample behind the centre (the heading tick is at the centre).
  CHECK(near(at(p0, p0.view.to_pixel(19.0, 15.0)), car, 24));
  CHECK(near(at(p0, p0.view.to_pixel(19.0, 15.6)), car, 24));
  o.time = 1.0;
  o.time_index.reset();
  MapPlot p10 = render_map(s, o);
  CHECK(p10.time_index == 10);
  CHECK(near(at(p10, p10.view.to_pixel(29.0, 15.0)), car, 24));
  CHECK_FALSE(near(at(p10, p10.view.to_pixel(19.0, 15.0)), car, 60));
  // The ego box is drawn in the ego colour at its own position.
  CHECK(near(at(p10, p10.view.to_pixel(14.0, 5.5)), kEgoColour, 24));
  // Boxes off: the car's pixel is plain road.
  o.boxes = false;
  MapPlot none = render_map(s, o);
  CHECK_FALSE(near(at(none, none.view.to_pixel(29.0, 15.0)), car, 60));
}

TEST_CASE("map plot: moving and static objects look different; stop signs are red") {
  const Scene s = synthetic_scene();
  const MapPlot p = render_map(s, {});
  const Rgba car = object_colour(ObjectType::Vehicle);
  const Rgba moving = at(p, p.view.to_pixel(19.0, 15.0)), parked = at(p, p.view.to_pixel(59.0, 17.5));
  CHECK(near(moving, car, 24));      // filled
  CHECK_FALSE(near(parked, car, 60)); // translucent inside ...
  CHECK(parked.b > parked.r + 20);    // ... but tinted by the type colour
  CHECK(near(at(p, p.view.to_pixel(60.0, 17.5 - 1.0)), car, 40));  // with a solid outline
  const Rgba stop = at(p, p.view.to_pixel(78.0, 2.0));
  CHECK(stop.r > 180);
  CHECK(stop.g < 80);
}

TEST_CASE("map plot: the road surface is as wide as the lane spacing") {
  Scene s;
  s.provenance.source_file = "lanes.json";
  for (int i = 0; i < 4; ++i)
    s.map.lanes.push_back({i, LaneType::SurfaceStreet, 0.0, false, line_pts({0, 3.8 * i}, {200, 3.8 * i}, 201), {}, {}, {}, {}});
  // A merging lane 2.5 m from lane 3 does not shrink the surface.
  s.map.lanes.push_back({9, LaneType::SurfaceStreet, 0.0, false, line_pts({0, 3.8 * 3 + 2.5}, {200, 3.8 * 3 + 2.5}, 201),
                         {}, {}, {}, {}});
  const MapPlot p = render_map(s, {});
  CHECK(p.lane_width_m == doctest::Approx(3.8));
  // Halfway between two lane centres the surface is as solid as next to a centre: no gap, no seam.
  CHECK(at(p, p.view.to_pixel(100.0, 1.9)) == at(p, p.view.to_pixel(100.0, 1.0)));
  CHECK_FALSE(at(p, p.view.to_pixel(100.0, 1.9)) == kPlotBackground);
  // Lanes 10 m apart are not neighbours: the default width.
  CHECK(render_map(synthetic_scene(), {}).lane_width_m == doctest::Approx(3.6));
}

TEST_CASE("map plot: the scale bar has a round length near a fifth of the width") {
  const MapPlot p = render_map(synthetic_scene(), {});
  // 1600 px over 120 m: 0.22 · 1576 px = 26.0 m -> 20 m.
  CHECK(p.scale_bar_m == 20.0);
  CHECK(round_scale_length(26.4) == 20.0);
  CHECK(round_scale_length(99.0) == 50.0);
  CHECK(round_scale_length(100.0) == 100.0);
  CHECK(round_scale_length(7.0) == 5.0);
  CHECK(round_scale_length(1999.0) == 1000.0);
  CHECK(round_scale_length(0.3) == 1.0);
  MapPlotOptions o;
  o.scale_bar = false;
  CHECK(render_map(synthetic_scene(), o).scale_bar_m == 0.0);
}

TEST_CASE("map plot: the legend lists the layers present with counts") {
  const MapPlot p = render_map(synthetic_scene(), {});
  auto has = [&](const std::string& label) {
    return std::find(p.legend.begin(), p.legend.end(), label) != p.legend.end();
  };
  CHECK(has("lanes (2)"));
  CHECK(has("road edge: boundary (2)"));
  CHECK(has("yellow double (1)"));
  CHECK(has("crosswalks (1)"));
  CHECK(has("stop signs (1)"));
  CHECK(has("driveways (1)"));
  CHECK(has("vehicle, moving (1)"));
  CHECK(has("vehicle, static (1)"));
  CHECK(has("ego"));
  CHECK(has("ego path (5 m)"));
  CHECK_FALSE(has("speed bumps (0)"));
  CHECK(p.legend.size() == 10);
  CHECK(p.title.find("synthetic.json") != std::string::npos);
  CHECK(p.title.find("t = 0.00 s") != std::string::npos);
}

TEST_CASE("map plot: empty scenes, non-finite coordinates and bad times are clear errors") {
  Scene empty;
  empty.provenance.source_file = "empty.json";
  try {
    render_map(empty, {});
    FAIL("expected an error");
  } catch (const InputError& e) {
    CHECK(std::string(e.what()) == "empty.json: nothing to plot: the scene has no map features, object boxes or ego poses");
  }
  Scene nan = synthetic_scene();
  nan.map.road_edges[0].points[1].y = std::numeric_limits<double>::quiet_NaN();
  CHECK_THROWS_WITH(render_map(nan, {}), "synthetic.json: map.road_edges[0].points[1]: coordinate is not finite");
  MapPlotOptions o;
  o.time = 5.0;
  CHECK_THROWS_WITH_AS(render_map(synthetic_scene(), o), "synthetic.json: time 5 s is outside the scene (0 to 1 s)",
                       InputError);
  o.time.reset();
  o.time_index = 11;
  CHECK_THROWS_AS(render_map(synthetic_scene(), o), InputError);
  o.time_index.reset();
  o.width = 10;
  CHECK_THROWS_AS(render_map(synthetic_scene(), o), std::invalid_argument);
}

TEST_CASE("map plot: a 10 km map fits the image and keeps thin edges visible") {
  Scene s;
  s.provenance.source_file = "big.xodr";
  s.map.road_edges.push_back({1, RoadEdgeType::Boundary, line_pts({0, 0}, {10000, 0}, 401)});
  s.map.road_edges.push_back({2, RoadEdgeType::Boundary, line_pts({0, 0}, {0, 10000}, 401)});
  s.map.road_edges.push_back({3, RoadEdgeType::Boundary, line_pts({0, 10000}, {10000, 0}, 401)});
  MapPlotOptions o;
  o.width = 1200;
  o.max_height = 1000;
  const MapPlot p = render_map(s, o);
  CHECK(p.image.width() == 1200);
  CHECK(p.image.height() <= 1000);
  // Every corner of the extent is inside the map area.
  for (glm::dvec2 w : {glm::dvec2(0, 0), glm::dvec2(10000, 0), glm::dvec2(0, 10000)}) {
    const glm::dvec2 q = p.view.to_pixel(w.x, w.y);
    CHECK(q.x >= 0);
    CHECK(q.x < p.image.width());
    CHECK(q.y >= p.view.map_y0);
    CHECK(q.y < p.view.map_y0 + p.view.map_height);
  }
  // The diagonal edge, under a pixel wide in metres (< 0.1 px/m), is still drawn bright.
  CHECK(p.view.pixels_per_metre < 0.1);
  int bright = 0;
  for (int i = 1; i < 20; ++i) {
    const glm::dvec2 q = p.view.to_pixel(i * 500.0, 10000.0 - i * 500.0);
    bright += at(p, q).r > 110;  // background r = 22
  }
  CHECK(bright >= 18);
  CHECK(p.scale_bar_m >= 1000.0);
}

TEST_CASE("map plot: plot_map_png writes an RGB PNG of the rendered size") {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "icube_test_map_plot";
  std::filesystem::create_directories(dir);
  const std::string path = (dir / "map.png").string();
  MapPlotOptions o;
  o.width = 640;
  plot_map_png(synthetic_scene(), o, path);
  int w = 0, h = 0, c = 0;
  REQUIRE(stbi_info(path.c_str(), &w, &h, &c) == 1);
  CHECK(w == 640);
  CHECK(h == render_map(synthetic_scene(), o).image.height());
  CHECK(c == 3);
  std::filesystem::remove_all(dir);
}

TEST_CASE("map plot: the real Waymo scenario and CARLA Town01") {
  const std::string data = icube::test::test_data_dir();
  if (data.empty()) return;  // skipped (or failed under ICUBE_REQUIRE_DATA=1)
  SUBCASE("Waymo scenario 637f20cafde22ff8") {
    const Scene s = load_scene(data + "/maps/waymo/motion_data_one_scenario.tfrecord");
    const MapPlot p = render_map(s, {});
    CHECK(p.time_index == 10);
    const double f = drawn_fraction(p);
    CAPTURE(f);
    CHECK(f > 0.10);
    CHECK(f < 0.90);
    auto has_prefix = [&](const std::string& prefix) {
      return std::any_of(p.legend.begin(), p.legend.end(), [&](const std::string& l) { return l.rfind(prefix, 0) == 0; });
    };
    CHECK(has_prefix("crosswalks (4)"));
    CHECK(has_prefix("speed bumps (3)"));
    CHECK(has_prefix("stop signs (8)"));
    CHECK(has_prefix("vehicle, "));
    CHECK(p.title.find("637f20cafde22ff8") != std::string::npos);
  }
  SUBCASE("CARLA Town01") {
    const Scene s = load_scene(data + "/maps/opendrive/carla/Town01.xodr");
    const MapPlot p = render_map(s, {});
    CHECK(p.time_index == -1);
    const double f = drawn_fraction(p);
    CAPTURE(f);
    CHECK(f > 0.05);
    CHECK(f < 0.60);  // a town grid: roads, not a filled square
    CHECK(p.view.map_height > 600);
  }
}

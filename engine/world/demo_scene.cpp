// The demo town (see demo_scene.h): geometry of one arm and its turns built
// for the west arm and rotated by quarter turns (exact: coordinates are
// swapped and negated, no trigonometry), paths as exact straight/arc
// segments, and 10 Hz tracks from speed profiles along those paths.
#include "world/demo_scene.h"

#include "scene/frames.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

namespace icube::world {

namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kHalfLane = 0.5 * kDemoLaneWidth;                    // 1.75: lane centre off the axis
constexpr double kEdge = kDemoLaneWidth + kDemoParkingWidth;          // 6: road edge off the axis
constexpr double kJ = kEdge + kDemoCurbRadius;                        // 12: junction mouth
constexpr double kCrossNear = kJ + 0.5, kCrossFar = kJ + 3.5;         // crosswalk band
constexpr double kLineEnd = kCrossFar + 0.5;                          // lines stop before the crosswalk
constexpr double kStopFront = kCrossFar + 1.0;                        // stopped cars' front bumper
constexpr double kParkOffset = kDemoLaneWidth + 0.5 * kDemoParkingWidth;  // 4.75
constexpr double kRate = 10.0;

double round_to(double v, double step) { return std::round(v / step) * step + 0.0; }
glm::dvec3 r3(glm::dvec2 p, double z = 0.0) { return {round_to(p.x, 1e-3), round_to(p.y, 1e-3), round_to(z, 1e-3)}; }

// Quarter turns counter-clockwise about the origin, exactly.
glm::dvec2 rot(glm::dvec2 p, int k) {
  for (int i = 0; i < ((k % 4) + 4) % 4; ++i) p = {-p.y, p.x};
  return p;
}

// ---- paths ----------------------------------------------------------------------------

struct Segment {
  bool arc = false;
  glm::dvec2 p0{0.0}, dir{1.0, 0.0};  // straight
  glm::dvec2 centre{0.0};             // arc
  double radius = 0.0, theta0 = 0.0, turn = 1.0;  // turn: +1 CCW, -1 CW
  double length = 0.0;
};

Segment straight(glm::dvec2 a, glm::dvec2 b) {
  Segment s;
  s.p0 = a;
  s.length = glm::length(b - a);
  s.dir = (b - a) / s.length;
  return s;
}

Segment arc(glm::dvec2 centre, double radius, double theta0, double sweep) {
  Segment s;
  s.arc = true;
  s.centre = centre, s.radius = radius, s.theta0 = theta0;
  s.turn = sweep >= 0.0 ? 1.0 : -1.0;
  s.length = radius * std::abs(sweep);
  return s;
}

Segment rotated(Segment s, int k) {
  s.p0 = rot(s.p0, k), s.dir = rot(s.dir, k), s.centre = rot(s.centre, k);
  s.theta0 += k * 0.5 * kPi;
  return s;
}

struct PathPoint {
  glm::dvec2 p{0.0};
  double heading = 0.0;
};

PathPoint eval(const Segment& s, double d) {
  if (!s.arc) return {s.p0 + s.dir * d, std::atan2(s.dir.y, s.dir.x)};
  const double th = s.theta0 + s.turn * d / s.radius;
  return {s.centre + s.radius * glm::dvec2(std::cos(th), std::sin(th)), th + s.turn * 0.5 * kPi};
}

struct Path {
  std::vector<Segment> segs;
  double length() const {
    double l = 0.0;
    for (const Segment& s : segs) l += s.length;
    return l;
  }
  PathPoint at(double d) const {
    for (const Segment& s : segs) {
      if (d <= s.length) return eval(s, std::max(d, 0.0));
      d -= s.length;
    }
    return eval(segs.back(), segs.back().length + d);
  }
};

// Polyline of a segment, points at most `step` apart (both ends included).
std::vector<glm::dvec3> sample(const Segment& s, double step) {
  const int n = std::max(1, static_cast<int>(std::ceil(s.length / step - 1e-9)));
  std::vector<glm::dvec3> out;
  for (int i = 0; i <= n; ++i) out.push_back(r3(eval(s, s.length * i / n).p));
  return out;
}

// West-arm geometry (k = 0), to be rotated by k quarter turns: the approach
// lane (eastbound at y = -1.75), the exit lane (westbound at y = +1.75), and
// the three turns from the approach. Arms: 0 west, 1 south, 2 east, 3 north.
Segment approach(int k, double from = kDemoArmLength) {
  return rotated(straight({-from, -kHalfLane}, {-kJ, -kHalfLane}), k);
}
Segment exit_lane(int k, double to = kDemoArmLength) { return rotated(straight({-kJ, kHalfLane}, {-to, kHalfLane}), k); }
enum Turn { Straight = 0, Left = 1, Right = 2 };
int turn_target(int k, Turn t) { return t == Straight ? (k + 2) % 4 : t == Left ? (k + 3) % 4 : (k + 1) % 4; }
Segment connector(int k, Turn t) {
  switch (t) {
    case Straight: return rotated(straight({-kJ, -kHalfLane}, {kJ, -kHalfLane}), k);
    case Left: return rotated(arc({-kJ, kJ}, kJ + kHalfLane, -0.5 * kPi, 0.5 * kPi), k);
    case Right: break;
  }
  return rotated(arc({-kJ, -kJ}, kJ - kHalfLane, 0.5 * kPi, -0.5 * kPi), k);
}
Path route(int k, Turn t, double from = kDemoArmLength) {
  return Path{{approach(k, from), connector(k, t), exit_lane(turn_target(k, t))}};
}

int64_t approach_id(int k) { return 100 + k; }
int64_t exit_id(int k) { return 110 + k; }
int64_t connector_id(int k, Turn t) { return 200 + 10 * k + t; }

// ---- map -------------------------------------------------------------------------------

scene::Map make_map() {
  scene::Map m;
  for (int k = 0; k < 4; ++k) {
    scene::Lane a;
    a.id = approach_id(k), a.type = scene::LaneType::SurfaceStreet, a.speed_limit_mph = 25.0;
    a.points = sample(approach(k), 2.0);
    for (Turn t : {Straight, Left, Right}) a.exit_lanes.push_back(connector_id(k, t));
    m.lanes.push_back(a);
    scene::Lane e;
    e.id = exit_id(k), e.type = scene::LaneType::SurfaceStreet, e.speed_limit_mph = 25.0;
    e.points = sample(exit_lane(k), 2.0);
    for (int from = 0; from < 4; ++from)
      for (Turn t : {Straight, Left, Right})
        if (turn_target(from, t) == k) e.entry_lanes.push_back(connector_id(from, t));
    std::sort(e.entry_lanes.begin(), e.entry_lanes.end());
    m.lanes.push_back(e);
  }
  for (int k = 0; k < 4; ++k)
    for (Turn t : {Straight, Left, Right}) {
      scene::Lane c;
      c.id = connector_id(k, t), c.type = scene::LaneType::SurfaceStreet, c.speed_limit_mph = 25.0;
      c.interpolating = true;
      c.points = sample(connector(k, t), 1.0);
      c.entry_lanes = {approach_id(k)};
      c.exit_lanes = {exit_id(turn_target(k, t))};
      m.lanes.push_back(c);
    }
  std::sort(m.lanes.begin(), m.lanes.end(), [](const scene::Lane& x, const scene::Lane& y) { return x.id < y.id; });

  for (int k = 0; k < 4; ++k) {
    // Centre line and the two lane/parking lines of arm k, from the arm's end towards the junction.
    auto line = [&](int64_t id, scene::RoadLineType type, double y, const char* what) {
      scene::RoadLine l;
      l.id = id, l.type = type, l.source_type = what;
      l.points = sample(rotated(straight({-kDemoArmLength, y}, {-kLineEnd, y}), k), 2.0);
      m.road_lines.push_back(l);
    };
    line(300 + 10 * k, scene::RoadLineType::SolidSingleYellow, 0.0, "centre");
    line(301 + 10 * k, scene::RoadLineType::BrokenSingleWhite, -kDemoLaneWidth, "lane/parking");
    line(302 + 10 * k, scene::RoadLineType::BrokenSingleWhite, kDemoLaneWidth, "lane/parking");

    // Curb of the corner between arm k and arm k+1 (west/south for k = 0).
    scene::RoadEdge edge;
    edge.id = 400 + k, edge.type = scene::RoadEdgeType::Boundary;
    for (const Segment& s : {straight({-kDemoArmLength, -kEdge}, {-kJ, -kEdge}),
                             arc({-kJ, -kJ}, kDemoCurbRadius, 0.5 * kPi, -0.5 * kPi),
                             straight({-kEdge, -kJ}, {-kEdge, -kDemoArmLength})}) {
      std::vector<glm::dvec3> pts = sample(rotated(s, k), s.arc ? 0.5 : 2.0);
      edge.points.insert(edge.points.end(), pts.begin() + (edge.points.empty() ? 0 : 1), pts.end());
    }
    m.road_edges.push_back(edge);

    scene::Polygon cw;
    cw.id = 500 + k;
    for (const glm::dvec2 q : {glm::dvec2(-kCrossFar, -kEdge), glm::dvec2(-kCrossNear, -kEdge),
                               glm::dvec2(-kCrossNear, kEdge), glm::dvec2(-kCrossFar, kEdge)})
      cw.points.push_back(r3(rot(q, k)));
    m.crosswalks.push_back(cw);
  }
  // Stop signs on the minor (north-south) road, on the right of each approach.
  for (int k : {1, 3}) {
    scene::StopSign s;
    s.id = 600 + k;
    s.position = r3(rot({-kStopFront, -(kEdge + 1.0)}, k), 0.0);
    s.lanes = {approach_id(k)};
    m.stop_signs.push_back(s);
  }
  return m;
}

// ---- tracks ------------------------------------------------------------------------------

struct Lwh {
  double l, w, h;
};

scene::BoxState box_at(const PathPoint& q, Lwh size, double speed) {
  scene::BoxState b;
  b.center = r3(q.p, 0.5 * size.h);
  b.length = size.l, b.width = size.w, b.height = size.h;
  b.heading = round_to(scene::wrap_angle(q.heading), 1e-6);
  b.velocity = {round_to(speed * std::cos(q.heading), 1e-3), round_to(speed * std::sin(q.heading), 1e-3)};
  b.valid = true;
  return b;
}

// Piecewise-linear speed over time (knots (t, v)); distance is its exact integral.
struct SpeedProfile {
  std::vector<glm::dvec2> knots;
  double speed(double t) const {
    if (t <= knots.front().x) return knots.front().y;
    for (size_t i = 1; i < knots.size(); ++i)
      if (t <= knots[i].x) {
        const double f = (t - knots[i - 1].x) / (knots[i].x - knots[i - 1].x);
        return knots[i - 1].y + f * (knots[i].y - knots[i - 1].y);
      }
    return knots.back().y;
  }
  double distance(double t) const {
    double d = 0.0, t0 = 0.0;
    for (size_t i = 0; i < knots.size() && t0 < t; ++i) {
      const double t1 = std::min(t, knots[i].x);
      if (t1 > t0) d += 0.5 * (speed(t0) + speed(t1)) * (t1 - t0);
      t0 = std::max(t0, t1);
    }
    if (t > t0) d += knots.back().y * (t - t0);
    return d;
  }
};

// A car driving `path` from arc length s0 with `profile`; invalid past the path's end.
scene::Track moving_car(int64_t id, const Path& path, double s0, const SpeedProfile& profile, Lwh size,
                        size_t frames) {
  scene::Track tr;
  tr.id = id, tr.type = scene::ObjectType::Vehicle;
  const double len = path.length();
  for (size_t i = 0; i < frames; ++i) {
    const double t = static_cast<double>(i) / kRate;
    const double s = s0 + profile.distance(t);
    tr.states.push_back(s >= 0.0 && s <= len ? box_at(path.at(s), size, profile.speed(t)) : scene::BoxState{});
  }
  return tr;
}

// Ego speed as a function of arc length: cruise, braking into the turn, turn speed, accelerating out.
struct EgoProfile {
  double cruise = 12.0, turn = 5.5, brake = 1.8, accel = 1.2, turn_start = 0.0, turn_end = 0.0;
  double speed(double s) const {
    if (s < turn_start) return std::min(cruise, std::sqrt(turn * turn + 2.0 * brake * (turn_start - s)));
    if (s <= turn_end) return turn;
    return std::min(cruise, std::sqrt(turn * turn + 2.0 * accel * (s - turn_end)));
  }
};

}  // namespace

scene::Scene make_demo_scene() {
  scene::Scene sc;
  sc.provenance.source_file = "demo_scene";
  sc.provenance.source_format = "icube-demo";
  sc.provenance.scenario_id = "icube-demo-junction";
  sc.provenance.source_version = "1";
  sc.prompt = "a sunny suburban junction";
  sc.map = make_map();
  sc.cameras.push_back(scene::waymo_front_camera());

  // Ego: from the west, left turn, out to the north.
  const double ego_from = kDemoArmLength - 2.0;
  Path ego_path = route(0, Left, ego_from);
  ego_path.segs.back().length -= 2.0;
  EgoProfile prof;
  prof.turn_start = ego_path.segs[0].length, prof.turn_end = prof.turn_start + ego_path.segs[1].length;
  std::vector<double> ego_s{0.0};
  constexpr int kSub = 100;  // midpoint integration, 1 ms steps
  while (ego_s.back() < ego_path.length()) {
    double s = ego_s.back();
    for (int j = 0; j < kSub; ++j) {
      const double h = 1.0 / (kRate * kSub);
      s += h * prof.speed(s + 0.5 * h * prof.speed(s));
    }
    ego_s.push_back(std::min(s, ego_path.length()));
  }
  const size_t frames = ego_s.size();
  for (size_t i = 0; i < frames; ++i) sc.timestamps.push_back(static_cast<double>(i) / kRate);

  const Lwh ego_size{4.6, 1.9, 1.6};
  scene::Track ego;
  ego.id = 0, ego.type = scene::ObjectType::Vehicle;
  for (size_t i = 0; i < frames; ++i) {
    const PathPoint q = ego_path.at(ego_s[i]);
    const scene::BoxState b = box_at(q, ego_size, prof.speed(ego_s[i]));
    ego.states.push_back(b);
    scene::EgoPose pose;
    const double c = round_to(std::cos(b.heading), 1e-12), s = round_to(std::sin(b.heading), 1e-12);
    pose.ego_to_world[0] = {c, s, 0.0, 0.0};
    pose.ego_to_world[1] = {-s, c, 0.0, 0.0};
    pose.ego_to_world[3] = {b.center.x, b.center.y, 0.0, 1.0};
    sc.ego.push_back(pose);
  }
  sc.tracks.push_back(ego);
  sc.sdc_track_index = 0;

  // Parked cars: (arm, side +1 = left of the approach, distance from the centre), headings along their lane.
  struct Parked {
    int arm;
    double side, dist;
    Lwh size;
  };
  const Parked parked[] = {
      {0, -1, 40.0, {4.5, 1.9, 1.6}},  {0, -1, 47.5, {4.2, 1.8, 1.5}},  {0, -1, 90.0, {4.8, 1.95, 1.65}},
      {0, 1, 60.0, {4.4, 1.85, 1.55}}, {0, 1, 120.0, {4.6, 1.9, 1.7}},  {2, 1, 35.0, {4.3, 1.8, 1.5}},
      {2, 1, 80.0, {4.7, 1.95, 1.6}},  {2, -1, 50.0, {4.5, 1.85, 1.55}}, {3, -1, 45.0, {4.9, 2.0, 1.7}},
      {1, 1, 40.0, {4.4, 1.9, 1.6}},
  };
  int64_t id = 1;
  for (const Parked& p : parked) {
    // Side -1 is the approach lane's right (its parking strip), +1 the exit lane's side.
    const glm::dvec2 pos = rot({-p.dist, p.side * kParkOffset}, p.arm);
    const glm::dvec2 dir = rot({p.side < 0 ? 1.0 : -1.0, 0.0}, p.arm);
    scene::Track tr;
    tr.id = id++, tr.type = scene::ObjectType::Vehicle;
    tr.states.assign(frames, box_at({pos, std::atan2(dir.y, dir.x)}, p.size, 0.0));
    sc.tracks.push_back(tr);
  }

  // Moving cars. Stop-sign stops: front bumper at kStopFront from the centre.
  const Lwh car{4.5, 1.9, 1.6};
  const double stop_s = (kDemoArmLength - kStopFront) - 0.5 * car.l;
  const SpeedProfile m3{{{0, 8}, {2, 8}, {6, 0}, {20, 0}, {25.5, 8}}};
  const SpeedProfile m4{{{0, 8}, {4, 8}, {8, 0}, {21.5, 0}, {27, 8}}};
  sc.tracks.push_back(moving_car(11, route(0, Straight), 40.0, SpeedProfile{{{0, 9.5}}}, car, frames));
  sc.tracks.push_back(moving_car(12, route(2, Straight), 50.0, SpeedProfile{{{0, 10.0}}}, {4.7, 1.95, 1.6}, frames));
  sc.tracks.push_back(moving_car(13, route(1, Right), stop_s - m3.distance(6.0), m3, {4.3, 1.85, 1.55}, frames));
  sc.tracks.push_back(moving_car(14, route(3, Straight), stop_s - m4.distance(8.0), m4, {4.6, 1.9, 1.65}, frames));

  // Pedestrians: across the south crosswalk (west to east), and along the east arm's north sidewalk (westwards).
  const Lwh ped{0.6, 0.6, 1.75};
  auto walker = [&](int64_t pid, glm::dvec2 a, glm::dvec2 b, double t0, double speed) {
    const double len = glm::length(b - a);
    const double heading = std::atan2(b.y - a.y, b.x - a.x);
    scene::Track tr;
    tr.id = pid, tr.type = scene::ObjectType::Pedestrian;
    for (size_t i = 0; i < frames; ++i) {
      const double t = static_cast<double>(i) / kRate;
      const double d = std::clamp((t - t0) * speed, 0.0, len);
      const bool walking = t > t0 && d < len;
      tr.states.push_back(box_at({a + (b - a) * (d / len), heading}, ped, walking ? speed : 0.0));
    }
    sc.tracks.push_back(tr);
  };
  const double cw_mid = -0.5 * (kCrossNear + kCrossFar);
  walker(21, {-(kEdge + 3.0), cw_mid}, {kEdge + 3.0, cw_mid}, 1.0, 1.3);
  walker(22, {60.0, kEdge + 2.5}, {20.0, kEdge + 2.5}, 0.0, 1.3);

  scene::classify_tracks(sc);
  return sc;
}

}  // namespace icube::world

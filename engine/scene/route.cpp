// Lane graph, seeded walk and constant-speed resampling for synthetic ego
// drives. See route.h.
#include "scene/route.h"

#include "scene/frames.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <stdexcept>
#include <unordered_map>

namespace icube::scene {

namespace {

std::string source_name(const Scene& scene) {
  return scene.provenance.source_file.empty() ? std::string("scene") : scene.provenance.source_file;
}

// SplitMix64: portable, so a seed gives the same route on every platform
// (std::uniform_int_distribution is implementation-defined).
uint64_t next_random(uint64_t& state) {
  uint64_t z = (state += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

size_t pick(uint64_t& state, size_t n) { return static_cast<size_t>(next_random(state) % n); }

double polyline_length(const std::vector<glm::dvec3>& p) {
  double len = 0.0;
  for (size_t i = 1; i < p.size(); ++i) len += glm::length(p[i] - p[i - 1]);
  return len;
}

bool usable(const Lane& l) { return l.points.size() >= 2 && polyline_length(l.points) > 1e-6; }

// Horizontal direction over the last (or first) `window` metres of a polyline.
glm::dvec2 end_direction(const std::vector<glm::dvec3>& p, bool at_end, double window = 1.0) {
  const size_t n = p.size();
  const glm::dvec3 anchor = at_end ? p[n - 1] : p[0];
  glm::dvec3 other = at_end ? p[0] : p[n - 1];
  double walked = 0.0;
  for (size_t k = 1; k < n; ++k) {
    const glm::dvec3& a = at_end ? p[n - k] : p[k - 1];
    const glm::dvec3& b = at_end ? p[n - 1 - k] : p[k];
    walked += glm::length(b - a);
    if (walked >= window) {
      other = b;
      break;
    }
  }
  glm::dvec2 d = at_end ? glm::dvec2(anchor - other) : glm::dvec2(other - anchor);
  const double len = glm::length(d);
  return len > 1e-12 ? d / len : glm::dvec2(1.0, 0.0);
}

void check_options(const RouteOptions& o) {
  auto bad = [](const char* what) { throw std::invalid_argument(std::string("route: ") + what); };
  if (!std::isfinite(o.length_m) || o.length_m <= 0.0) bad("length must be a finite number of metres > 0");
  if (!std::isfinite(o.speed_mps) || o.speed_mps <= 0.0) bad("speed must be a finite number of m/s > 0");
  if (!std::isfinite(o.rate_hz) || o.rate_hz <= 0.0) bad("rate must be a finite number of Hz > 0");
  if (!std::isfinite(o.connect_distance_m) || o.connect_distance_m < 0.0) bad("connect distance must be >= 0");
  if (!std::isfinite(o.connect_angle_deg) || o.connect_angle_deg < 0.0 || o.connect_angle_deg > 180.0)
    bad("connect angle must be in [0, 180] degrees");
  if (!std::isfinite(o.heading_smoothing_m) || o.heading_smoothing_m < 0.0) bad("heading smoothing must be >= 0");
  if (o.length_m / (o.speed_mps / o.rate_hz) > 1e7) bad("length / step gives more than 10 million poses");
}

// A polyline with cumulative arc length, sampled by arc length.
struct Path {
  std::vector<glm::dvec3> points;
  std::vector<double> cum{0.0};

  void append(const glm::dvec3& p) {
    if (points.empty()) {
      points.push_back(p);
      return;
    }
    const double d = glm::length(p - points.back());
    if (d <= 1e-9) return;
    points.push_back(p);
    cum.push_back(cum.back() + d);
  }
  double length() const { return cum.back(); }
  glm::dvec3 at(double s) const {
    if (points.size() == 1 || s <= 0.0) return points.front();
    if (s >= length()) return points.back();
    const size_t i = static_cast<size_t>(std::upper_bound(cum.begin(), cum.end(), s) - cum.begin());  // cum[i-1] <= s < cum[i]
    const double t = (s - cum[i - 1]) / (cum[i] - cum[i - 1]);
    return points[i - 1] + t * (points[i] - points[i - 1]);
  }
};

// Gaussian smoothing along the samples with a window truncated symmetrically
// near the ends, so a heading that changes linearly with distance (a circular
// arc) is reproduced exactly.
std::vector<double> smooth(const std::vector<double>& v, double step, double sigma) {
  if (sigma <= 0.0 || v.size() < 3) return v;
  const size_t n = v.size();
  std::vector<double> out(n);
  const int reach = static_cast<int>(std::floor(3.0 * sigma / step));
  for (size_t k = 0; k < n; ++k) {
    const int m = std::min({reach, static_cast<int>(k), static_cast<int>(n - 1 - k)});
    double sum = 0.0, wsum = 0.0;
    for (int j = -m; j <= m; ++j) {
      const double ds = j * step / sigma;
      const double w = std::exp(-0.5 * ds * ds);
      sum += w * v[static_cast<size_t>(static_cast<int>(k) + j)];
      wsum += w;
    }
    out[k] = sum / wsum;
  }
  return out;
}

double link_gap(const Lane& from, const Lane& to) { return glm::length(to.points.front() - from.points.back()); }

// Strongly connected components of the lane graph, each listed before every
// component that leads to it (Tarjan's algorithm, without recursion: a chain
// of thousands of lanes would overflow the stack).
std::vector<std::vector<size_t>> components_sinks_first(const std::vector<std::vector<size_t>>& succ) {
  constexpr size_t kUnseen = static_cast<size_t>(-1);
  const size_t n = succ.size();
  std::vector<size_t> index(n, kUnseen), low(n, 0), stack;
  std::vector<bool> on_stack(n, false);
  std::vector<std::pair<size_t, size_t>> calls;  // lane, next successor to visit
  std::vector<std::vector<size_t>> out;
  size_t counter = 0;
  auto open = [&](size_t v) {
    index[v] = low[v] = counter++;
    stack.push_back(v);
    on_stack[v] = true;
    calls.emplace_back(v, 0);
  };
  for (size_t root = 0; root < n; ++root) {
    if (index[root] != kUnseen) continue;
    open(root);
    while (!calls.empty()) {
      const size_t v = calls.back().first;
      if (calls.back().second < succ[v].size()) {
        const size_t w = succ[v][calls.back().second++];
        if (index[w] == kUnseen) open(w);
        else if (on_stack[w]) low[v] = std::min(low[v], index[w]);
        continue;
      }
      calls.pop_back();
      if (!calls.empty()) low[calls.back().first] = std::min(low[calls.back().first], low[v]);
      if (low[v] != index[v]) continue;
      std::vector<size_t>& component = out.emplace_back();
      size_t w;
      do {
        w = stack.back();
        stack.pop_back();
        on_stack[w] = false;
        component.push_back(w);
      } while (w != v);
    }
  }
  return out;
}

// For every lane, the longest drive (metres, capped at `cap`) that starts at
// its first point: its own length, then the gap to a successor's first point
// and that successor's reach. A lane on a cycle can be driven round for ever
// and reaches the cap.
std::vector<double> drivable_reach(const std::vector<Lane>& lanes, const std::vector<std::vector<size_t>>& succ,
                                   double cap) {
  std::vector<double> reach(lanes.size(), 0.0);
  for (const std::vector<size_t>& component : components_sinks_first(succ)) {
    const size_t v = component.front();
    const bool cycle = component.size() > 1 || std::find(succ[v].begin(), succ[v].end(), v) != succ[v].end();
    if (cycle) {
      for (size_t w : component) reach[w] = cap;
      continue;
    }
    double beyond = 0.0;  // successors lie in components already done
    for (size_t w : succ[v]) beyond = std::max(beyond, link_gap(lanes[v], lanes[w]) + reach[w]);
    reach[v] = std::min(cap, polyline_length(lanes[v].points) + beyond);
  }
  return reach;
}

constexpr double kReachSlack = 1e-6;  // metres of rounding allowed when comparing reaches

// The lane to drive after `cur`: seeded among the successors from which the
// remaining metres can still be driven, else among those that go furthest.
size_t choose_successor(const std::vector<Lane>& lanes, size_t cur, const std::vector<size_t>& next,
                        const std::vector<double>& reach, double remaining, uint64_t& rng) {
  std::vector<double> via(next.size());
  double furthest = 0.0;
  for (size_t k = 0; k < next.size(); ++k) {
    via[k] = link_gap(lanes[cur], lanes[next[k]]) + reach[next[k]];
    furthest = std::max(furthest, via[k]);
  }
  const double needed = std::min(remaining, furthest) - kReachSlack;
  std::vector<size_t> fit;
  for (size_t k = 0; k < next.size(); ++k)
    if (via[k] >= needed) fit.push_back(next[k]);
  return fit[pick(rng, fit.size())];
}

// The lanes a drive may start on: car lanes (any lanes when the map has none)
// from which the whole length can be driven, else those that go furthest.
std::vector<size_t> start_candidates(const std::vector<Lane>& lanes, const std::vector<double>& reach, double length) {
  std::vector<size_t> pool;
  for (size_t i = 0; i < lanes.size(); ++i)
    if (usable(lanes[i]) && lanes[i].type != LaneType::BikeLane) pool.push_back(i);
  if (pool.empty())
    for (size_t i = 0; i < lanes.size(); ++i)
      if (usable(lanes[i])) pool.push_back(i);
  double furthest = 0.0;
  for (size_t i : pool) furthest = std::max(furthest, reach[i]);
  const double needed = std::min(length, furthest) - kReachSlack;
  std::vector<size_t> out;
  for (size_t i : pool)
    if (reach[i] >= needed) out.push_back(i);
  return out;
}

}  // namespace

std::vector<std::vector<size_t>> lane_successors(const Map& map, const RouteOptions& options) {
  const std::vector<Lane>& lanes = map.lanes;
  const size_t n = lanes.size();
  std::vector<std::vector<size_t>> succ(n);
  std::vector<bool> ok(n);
  std::unordered_map<int64_t, size_t> by_id;
  for (size_t i = 0; i < n; ++i) {
    ok[i] = usable(lanes[i]);
    by_id.emplace(lanes[i].id, i);  // the first lane wins when ids repeat
  }
  // Lane starts bucketed on a grid of cells >= the connect distance.
  const double cell = std::max(options.connect_distance_m, 0.1);
  auto key = [&](double x, double y) {
    const auto cx = static_cast<int64_t>(std::floor(x / cell)), cy = static_cast<int64_t>(std::floor(y / cell));
    return (static_cast<uint64_t>(cx) * 0x9E3779B97F4A7C15ull) ^ static_cast<uint64_t>(cy);
  };
  std::unordered_multimap<uint64_t, size_t> starts;
  for (size_t j = 0; j < n; ++j)
    if (ok[j]) starts.emplace(key(lanes[j].points.front().x, lanes[j].points.front().y), j);
  const double cos_limit = std::cos(options.connect_angle_deg * std::numbers::pi / 180.0);
  // Lanes starting near lane i's end, heading the same way.
  auto add_nearby_starts = [&](size_t i, std::vector<size_t>& out) {
    const glm::dvec3 end = lanes[i].points.back();
    const glm::dvec2 dir = end_direction(lanes[i].points, true);
    for (int ox = -1; ox <= 1; ++ox)
      for (int oy = -1; oy <= 1; ++oy) {
        auto [a, b] = starts.equal_range(key(end.x + ox * cell, end.y + oy * cell));
        for (auto it = a; it != b; ++it) {
          const size_t j = it->second;
          if (j == i || glm::length(lanes[j].points.front() - end) > options.connect_distance_m) continue;
          if (glm::dot(dir, end_direction(lanes[j].points, false)) < cos_limit) continue;
          out.push_back(j);
        }
      }
  };
  for (size_t i = 0; i < n; ++i) {
    if (!ok[i]) continue;
    for (int64_t id : lanes[i].exit_lanes) {
      auto it = by_id.find(id);
      if (it != by_id.end() && ok[it->second]) succ[i].push_back(it->second);
    }
    if (succ[i].empty()) add_nearby_starts(i, succ[i]);
    std::sort(succ[i].begin(), succ[i].end());
    succ[i].erase(std::unique(succ[i].begin(), succ[i].end()), succ[i].end());
  }
  return succ;
}

Scene sample_route(const Scene& in, const RouteOptions& options, RouteReport* report) {
  check_options(options);
  const std::string file = source_name(in);
  const std::vector<Lane>& lanes = in.map.lanes;
  const std::vector<std::vector<size_t>> succ = lane_successors(in.map, options);
  const std::vector<double> reach = drivable_reach(lanes, succ, options.length_m);
  uint64_t rng = options.seed;

  // Start lane.
  size_t cur = 0;
  if (options.start_lane) {
    auto it = std::find_if(lanes.begin(), lanes.end(), [&](const Lane& l) { return l.id == *options.start_lane; });
    if (it == lanes.end()) throw InputError(file, "", "no lane with id " + std::to_string(*options.start_lane));
    if (!usable(*it))
      throw InputError(file, "", "lane " + std::to_string(*options.start_lane) + " has fewer than two distinct points");
    cur = static_cast<size_t>(it - lanes.begin());
  } else {
    const std::vector<size_t> from = start_candidates(lanes, reach, options.length_m);
    if (from.empty())
      throw InputError(file, "",
                       lanes.empty() ? "no lanes to drive along: the map has no lane centre lines"
                                     : "no lanes to drive along: no lane centre line has two distinct points");
    cur = from[pick(rng, from.size())];
  }
  const size_t start_index = cur;

  // Walk the lane graph until the path is long enough or ends, at every fork
  // towards a lane from which the rest of the length can be driven.
  Path path;
  std::vector<std::pair<int64_t, double>> driven;  // lane id, arc length where it starts
  auto take = [&](size_t lane) {
    driven.emplace_back(lanes[lane].id, path.points.empty() ? 0.0 : path.length());
    for (const glm::dvec3& p : lanes[lane].points) path.append(p);
  };
  take(cur);
  bool dead_end = false;
  constexpr size_t kMaxLanes = 1000000;  // reached only on loops of near-zero-length lanes
  while (path.length() < options.length_m && driven.size() < kMaxLanes) {
    if (succ[cur].empty()) {
      dead_end = true;
      break;
    }
    cur = choose_successor(lanes, cur, succ[cur], reach, options.length_m - path.length(), rng);
    take(cur);
  }

  const double step = options.speed_mps / options.rate_hz;
  const double drive = std::min(path.length(), options.length_m);
  const size_t steps = static_cast<size_t>(std::floor(drive / step + 1e-9));
  if (steps == 0) {
    char buf[160];
    std::snprintf(buf, sizeof buf, "the drive from lane %lld reaches a dead end after %.2f m, less than one %.2f m step",
                  static_cast<long long>(driven.front().first), path.length(), step);
    throw InputError(file, "", buf);
  }

  // Poses: position on the path, tangent from a chord centred on the sample.
  const size_t n = steps + 1;
  const double h = std::max(0.5, 0.5 * step);
  std::vector<double> yaw(n), pitch(n);
  std::vector<glm::dvec3> pos(n);
  for (size_t k = 0; k < n; ++k) {
    const double sk = static_cast<double>(k) * step;
    pos[k] = path.at(sk);
    const glm::dvec3 d = path.at(std::min(sk + h, path.length())) - path.at(std::max(sk - h, 0.0));
    yaw[k] = std::atan2(d.y, d.x);
    pitch[k] = std::atan2(d.z, std::hypot(d.x, d.y));
    if (k > 0) {  // unwrap, so smoothing never averages across ±pi
      while (yaw[k] - yaw[k - 1] > std::numbers::pi) yaw[k] -= 2.0 * std::numbers::pi;
      while (yaw[k] - yaw[k - 1] < -std::numbers::pi) yaw[k] += 2.0 * std::numbers::pi;
    }
  }
  yaw = smooth(yaw, step, options.heading_smoothing_m);
  pitch = smooth(pitch, step, options.heading_smoothing_m);

  Scene out = in;
  out.timestamps.resize(n);
  out.ego.resize(n);
  for (size_t k = 0; k < n; ++k) {
    out.timestamps[k] = static_cast<double>(k) / options.rate_hz;
    const glm::dvec3 f(std::cos(pitch[k]) * std::cos(yaw[k]), std::cos(pitch[k]) * std::sin(yaw[k]), std::sin(pitch[k]));
    const glm::dvec3 l(-std::sin(yaw[k]), std::cos(yaw[k]), 0.0);
    const glm::dvec3 u = glm::cross(f, l);
    glm::dmat4 m(1.0);
    m[0] = glm::dvec4(f, 0.0), m[1] = glm::dvec4(l, 0.0), m[2] = glm::dvec4(u, 0.0), m[3] = glm::dvec4(pos[k], 1.0);
    out.ego[k] = EgoPose{m, true};
  }
  out.current_time_index = 0;
  out.sdc_track_index = -1;

  RouteReport rep;
  auto drop_missing = [&](const char* what) { std::erase(out.missing, std::string(what)); };
  auto add_missing = [&](const char* what) {
    if (std::find(out.missing.begin(), out.missing.end(), what) == out.missing.end()) out.missing.emplace_back(what);
  };
  drop_missing("ego trajectory");
  if (out.cameras.empty()) out.cameras.push_back(waymo_front_camera(kRouteCameraMount));
  drop_missing("cameras");
  if (!out.tracks.empty()) {
    rep.notes.push_back("dropped " + std::to_string(out.tracks.size()) +
                        " object track(s): they follow the input's timestamps, not the route's");
    out.tracks.clear();
    add_missing("object boxes");
  }

  const double driven_len = static_cast<double>(steps) * step;
  for (const auto& [id, start] : driven)
    if (start <= driven_len || rep.lanes.empty()) rep.lanes.push_back(id);
  rep.length_m = driven_len;
  rep.poses = n;
  rep.dead_end = dead_end;
  rep.longest_possible_m = reach[start_index];
  if (!dead_end && path.length() < options.length_m) {
    char buf[200];
    std::snprintf(buf, sizeof buf, "stopped after %zu lanes at %.1f m of the requested %.1f m (the lanes are very short)",
                  kMaxLanes, driven_len, options.length_m);
    rep.notes.push_back(buf);
  }
  if (dead_end) {
    char buf[320];
    std::snprintf(buf, sizeof buf,
                  "stopped at a dead end after %.1f m of the requested %.1f m: lane %lld has no successor; the longest "
                  "drive the lanes allow from lane %lld is %.1f m%s",
                  driven_len, options.length_m, static_cast<long long>(driven.back().first),
                  static_cast<long long>(lanes[start_index].id), reach[start_index],
                  options.start_lane ? "" : " (no start lane leads further)");
    rep.notes.insert(rep.notes.begin(), buf);
  }
  if (report) *report = std::move(rep);
  return out;
}

}  // namespace icube::scene

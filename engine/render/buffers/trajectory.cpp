// Trajectory sources and selections; see trajectory.h.
#include "render/buffers/trajectory.h"

#include "scene/atomic_file.h"
#include "scene/frames.h"
#include "scene/input_error.h"
#include "world/npy.h"

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdlib>
#include <sstream>
#include <stdexcept>

namespace icube::render {

namespace {

bool ends_with(const std::string& s, const std::string& suf) {
  return s.size() >= suf.size() && s.compare(s.size() - suf.size(), suf.size(), suf) == 0;
}

void check_pose(const glm::dmat4& m, const std::string& path, const std::string& where) {
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r)
      if (!std::isfinite(m[c][r])) throw scene::InputError(path, where, "non-finite pose entry");
  const glm::dmat3 R(m);
  const double det = glm::determinant(R);
  if (std::fabs(det - 1.0) > 1e-3) throw scene::InputError(path, where, "rotation part is not a rotation (det " + std::to_string(det) + ")");
}

int time_for(size_t i, size_t scene_states) {
  if (scene_states == 0) return -1;
  return static_cast<int>(std::min(i, scene_states - 1));
}

TrajectoryFile load_npy_trajectory(const std::string& path, size_t scene_states) {
  const world::NpyArray a = world::read_npy(path);
  if (a.dtype != world::NpyDtype::F4 && a.dtype != world::NpyDtype::F8)
    throw scene::InputError(path, "dtype", "expected float32 or float64 poses");
  size_t passes = 0, n = 0;
  if (a.shape.size() == 3 && a.shape[1] == 4 && a.shape[2] == 4) {
    passes = 1;
    n = a.shape[0];
  } else if (a.shape.size() == 4 && a.shape[2] == 4 && a.shape[3] == 4) {
    passes = a.shape[0];
    n = a.shape[1];
  } else {
    throw scene::InputError(path, "shape", "expected [N,4,4] or [P,N,4,4] camera-to-world poses");
  }
  if (passes == 0 || n == 0) throw scene::InputError(path, "shape", "no poses");
  TrajectoryFile out;
  for (size_t p = 0; p < passes; ++p) {
    Trajectory t;
    for (size_t i = 0; i < n; ++i) {
      glm::dmat4 m(1.0);
      const size_t base = (p * n + i) * 16;
      for (int r = 0; r < 4; ++r)
        for (int c = 0; c < 4; ++c) m[c][r] = a.as_double(base + static_cast<size_t>(4 * r + c));
      check_pose(m, path, "pose " + std::to_string(i) + (passes > 1 ? " of pass " + std::to_string(p) : ""));
      t.c2w.push_back(m);
      t.frame_index.push_back(static_cast<int>(i));
      t.time_index.push_back(time_for(i, scene_states));
    }
    out.passes.push_back(std::move(t));
  }
  return out;
}

TrajectoryFile load_json_trajectory(const std::string& path, size_t scene_states) {
  const std::string text = scene::read_file(path);
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {
    throw scene::InputError(path, "", std::string("not valid JSON: ") + e.what());
  }
  // Typed checks before any get(): json::value() throws type_error on a key of another type.
  if (!j.is_object() || !j.contains("format") || !j["format"].is_string() ||
      j["format"].get<std::string>() != "icube-trajectory")
    throw scene::InputError(path, "format", "expected {\"format\": \"icube-trajectory\", ...}");
  if (!j.contains("version") || !j["version"].is_number_integer() || j["version"].get<long long>() != 1)
    throw scene::InputError(path, "version", "only version 1 is supported");
  if (!j.contains("poses") || !j["poses"].is_array() || j["poses"].empty())
    throw scene::InputError(path, "poses", "expected a non-empty array of 4x4 matrices");
  TrajectoryFile out;
  Trajectory t;
  const auto& poses = j["poses"];
  for (size_t i = 0; i < poses.size(); ++i) {
    const std::string where = "poses[" + std::to_string(i) + "]";
    const auto& p = poses[i];
    if (!p.is_array() || p.size() != 4) throw scene::InputError(path, where, "expected 4 rows");
    glm::dmat4 m(1.0);
    for (int r = 0; r < 4; ++r) {
      const auto& row = p[static_cast<size_t>(r)];
      if (!row.is_array() || row.size() != 4) throw scene::InputError(path, where, "expected rows of 4 numbers");
      for (int c = 0; c < 4; ++c) {
        const auto& v = row[static_cast<size_t>(c)];
        if (!v.is_number()) throw scene::InputError(path, where, "expected numbers");
        m[c][r] = v.get<double>();
      }
    }
    check_pose(m, path, where);
    t.c2w.push_back(m);
    t.frame_index.push_back(static_cast<int>(i));
    t.time_index.push_back(time_for(i, scene_states));
  }
  if (j.contains("time_indices")) {
    const auto& ti = j["time_indices"];
    if (!ti.is_array() || ti.size() != t.size())
      throw scene::InputError(path, "time_indices", "expected one integer per pose");
    for (size_t i = 0; i < ti.size(); ++i) {
      if (!ti[i].is_number_integer()) throw scene::InputError(path, "time_indices", "expected integers");
      const long v = ti[i].get<long>();
      if (v < -1 || (scene_states > 0 && v >= static_cast<long>(scene_states)))
        throw scene::InputError(path, "time_indices[" + std::to_string(i) + "]", "out of the scene's range");
      t.time_index[i] = static_cast<int>(v);
    }
  }
  if (j.contains("camera")) {
    const auto& c = j["camera"];
    try {
      PinholeIntrinsics K{c.at("fx").get<double>(), c.at("fy").get<double>(), c.at("cx").get<double>(),
                          c.at("cy").get<double>(), c.at("width").get<uint32_t>(), c.at("height").get<uint32_t>()};
      Camera cam;
      cam.K = K;
      validate_camera(cam);
      out.camera = K;
    } catch (const std::exception& e) {
      throw scene::InputError(path, "camera", std::string("expected fx, fy, cx, cy, width, height: ") + e.what());
    }
  }
  out.passes.push_back(std::move(t));
  return out;
}

}  // namespace

std::string trajectory_json(const std::vector<glm::dmat4>& c2w, const std::optional<PinholeIntrinsics>& camera,
                            const std::vector<int>* time_indices) {
  if (time_indices && time_indices->size() != c2w.size())
    throw std::invalid_argument("trajectory_json: one time index per pose");
  nlohmann::ordered_json j;
  j["format"] = "icube-trajectory";
  j["version"] = 1;
  nlohmann::ordered_json poses = nlohmann::ordered_json::array();
  for (const glm::dmat4& m : c2w) {
    nlohmann::ordered_json rows = nlohmann::ordered_json::array();
    for (int r = 0; r < 4; ++r) rows.push_back({m[0][r], m[1][r], m[2][r], m[3][r]});
    poses.push_back(rows);
  }
  j["poses"] = poses;
  if (camera)
    j["camera"] = {{"fx", camera->fx}, {"fy", camera->fy}, {"cx", camera->cx},
                   {"cy", camera->cy}, {"width", camera->width}, {"height", camera->height}};
  if (time_indices) j["time_indices"] = *time_indices;
  return j.dump(1) + "\n";
}

namespace {

long parse_long(const std::string& s, const std::string& what) {
  char* end = nullptr;
  const long v = std::strtol(s.c_str(), &end, 10);
  if (s.empty() || *end != '\0' || v < 0) throw std::invalid_argument("--frames: bad " + what + " '" + s + "'");
  return v;
}

}  // namespace

Trajectory ego_trajectory(const scene::Scene& s, const scene::Camera& cam) {
  Trajectory t;
  for (size_t i = 0; i < s.ego.size(); ++i) {
    if (!s.ego[i].valid) continue;
    t.c2w.push_back(scene::camera_to_world_opencv(s.ego[i], cam));
    t.frame_index.push_back(static_cast<int>(i));
    t.time_index.push_back(static_cast<int>(i));
  }
  return t;
}

Trajectory route_trajectory(const scene::Scene& s, const scene::Camera& cam, const scene::RouteOptions& options,
                            scene::RouteReport* report) {
  // The route only needs the lanes: the cars keep the original scene's clock (below), so
  // sample_route's "tracks dropped" does not apply here.
  scene::Scene lanes_only = s;
  lanes_only.tracks.clear();
  const scene::Scene routed = scene::sample_route(lanes_only, options, report);
  Trajectory t = ego_trajectory(routed, cam);
  const size_t states = s.timestamps.size();
  for (size_t i = 0; i < t.size(); ++i) t.time_index[i] = time_for(static_cast<size_t>(t.frame_index[i]), states);
  return t;
}

TrajectoryFile load_trajectory(const std::string& path, size_t scene_states) {
  const bool npy = ends_with(path, ".npy") || scene::read_file(path).rfind("\x93NUMPY", 0) == 0;
  return npy ? load_npy_trajectory(path, scene_states) : load_json_trajectory(path, scene_states);
}

FrameRange parse_frame_range(const std::string& text) {
  FrameRange r;
  const size_t colon = text.find(':');
  if (colon == std::string::npos) {
    r.begin = parse_long(text, "frame");
    r.end = r.begin + 1;
    return r;
  }
  const std::string a = text.substr(0, colon);
  std::string b = text.substr(colon + 1);
  const size_t colon2 = b.find(':');
  if (colon2 != std::string::npos) {
    const std::string st = b.substr(colon2 + 1);
    b = b.substr(0, colon2);
    r.step = st.empty() ? 1 : parse_long(st, "step");
    if (r.step < 1) throw std::invalid_argument("--frames: step must be >= 1 in '" + text + "'");
  }
  r.begin = a.empty() ? 0 : parse_long(a, "start");
  r.end = b.empty() ? -1 : parse_long(b, "end");
  if (r.end >= 0 && r.end <= r.begin) throw std::invalid_argument("--frames: empty range '" + text + "'");
  return r;
}

Trajectory select_frames(const Trajectory& t, const FrameRange& r) {
  const size_t b = static_cast<size_t>(std::max(0L, r.begin));
  const size_t e = r.end < 0 ? t.size() : std::min(t.size(), static_cast<size_t>(r.end));
  if (b >= e)
    throw std::invalid_argument("--frames selects no frame (the trajectory has " + std::to_string(t.size()) + ")");
  Trajectory out;
  for (size_t i = b; i < e; i += static_cast<size_t>(r.step)) {
    out.c2w.push_back(t.c2w[i]);
    out.frame_index.push_back(t.frame_index[i]);
    out.time_index.push_back(t.time_index[i]);
  }
  return out;
}

PinholeIntrinsics parse_camera(const std::string& text) {
  std::vector<double> v;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) {
    char* end = nullptr;
    const double d = std::strtod(item.c_str(), &end);
    if (item.empty() || *end != '\0') throw std::invalid_argument("--camera: bad number '" + item + "'");
    v.push_back(d);
  }
  if (v.size() != 6) throw std::invalid_argument("--camera: expected fx,fy,cx,cy,w,h");
  if (!(v[4] >= 1 && v[5] >= 1 && v[4] <= 16384 && v[5] <= 16384 && v[4] == std::floor(v[4]) && v[5] == std::floor(v[5])))
    throw std::invalid_argument("--camera: width and height must be integers in 1..16384");
  PinholeIntrinsics K{v[0], v[1], v[2], v[3], static_cast<uint32_t>(v[4]), static_cast<uint32_t>(v[5])};
  Camera c;
  c.K = K;
  validate_camera(c);
  return K;
}

scene::Camera camera_preset(const std::string& name) {
  if (name == "waymo-front-480p") return scene::waymo_front_camera();
  throw std::invalid_argument("--camera-preset: unknown preset '" + name + "' (known: waymo-front-480p)");
}

PinholeIntrinsics intrinsics_of(const scene::Camera& c) { return {c.fx, c.fy, c.cx, c.cy, c.width, c.height}; }

}  // namespace icube::render

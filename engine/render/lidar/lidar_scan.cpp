// One LiDAR sweep on the GPU and its hits to returns; see lidar_scan.h.
#include "render/lidar/lidar_scan.h"

#include "world/semantics.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <stdexcept>

namespace icube::render {

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// Indexed by class id (semantics.h order). Assumed values; see the header.
constexpr std::array<float, world::kNumSemanticClasses> kReflectivity = {
    0.00f,  // undefined
    0.50f,  // car (painted metal, glass averaged)
    0.50f,  // truck
    0.50f,  // bus
    0.50f,  // other vehicle
    0.35f,  // motorcyclist
    0.35f,  // bicyclist
    0.35f,  // pedestrian (clothing, skin)
    0.90f,  // sign (retro-reflective sheeting)
    0.60f,  // traffic light
    0.45f,  // pole (painted / galvanised metal)
    0.80f,  // construction cone (retro-reflective bands)
    0.40f,  // bicycle
    0.45f,  // motorcycle
    0.40f,  // building (concrete, brick)
    0.55f,  // vegetation (leaves are bright in the near infrared)
    0.30f,  // tree trunk (bark)
    0.35f,  // curb (concrete)
    0.15f,  // road (asphalt)
    0.70f,  // lane marker (retro-reflective paint)
    0.25f,  // other ground (soil, gravel)
    0.30f,  // walkable
    0.35f,  // sidewalk (concrete)
};

const LidarModel& validated(const LidarModel& m) {
  validate_lidar(m);
  return m;
}

}  // namespace

float lidar_reflectivity(uint8_t class_id) {
  return class_id < kReflectivity.size() ? kReflectivity[class_id] : 0.0f;
}

float lidar_intensity(uint8_t class_id, int axis, const glm::dvec3& dir_world) {
  const double c = axis >= 0 && axis < 3 ? std::fabs(dir_world[axis]) : 1.0;
  return std::clamp(static_cast<float>(static_cast<double>(lidar_reflectivity(class_id)) * c), 0.0f, 1.0f);
}

int lidar_entry_axis(const glm::dvec3& p, const glm::dvec3& grid_origin, double voxel_size) {
  int best = 0;
  double best_d = INFINITY;
  for (int a = 0; a < 3; ++a) {
    const double q = (p[a] - grid_origin[a]) / voxel_size;
    const double d = std::fabs(q - std::round(q));
    if (d < best_d) {
      best_d = d;
      best = a;
    }
  }
  return best;
}

RaycastOptions lidar_raycast_options(const LidarModel& m, double voxel_size) {
  RaycastOptions o;
  o.t_max = m.max_range + o.eps_depth + 2.0 * voxel_size;
  return o;
}

std::vector<Ray> lidar_rays(const std::vector<glm::dvec3>& dirs_sensor, const glm::dmat4& s2w) {
  const glm::dmat3 R(s2w);
  const glm::dvec3 o(s2w[3]);
  std::vector<Ray> rays(dirs_sensor.size());
  for (size_t i = 0; i < dirs_sensor.size(); ++i) rays[i] = {o, glm::normalize(R * dirs_sensor[i])};
  return rays;
}

LidarScan lidar_scan_from_hits(const LidarModel& m, const std::vector<glm::dvec3>& dirs,
                               const glm::dmat4& s2w, const std::vector<shader::RaycastHit>& hits,
                               const glm::dvec3& grid_origin, double voxel_size) {
  if (dirs.size() != m.rays() || hits.size() != m.rays())
    throw std::invalid_argument("lidar: hit or direction count differs from beams x columns");
  LidarScan s;
  s.sensor_to_world = s2w;
  s.beams = m.beams();
  s.columns = m.columns;
  s.range.assign(hits.size(), 0.0f);
  const glm::dmat3 R(s2w);
  for (size_t i = 0; i < hits.size(); ++i) {
    const shader::RaycastHit& h = hits[i];
    if (!(h.flags & RAYCAST_FLAG_DEPTH)) continue;
    const double t = static_cast<double>(h.t_depth);
    if (t < m.min_range || t > m.max_range) continue;
    LidarReturn r;
    const glm::dvec3 ps = t * dirs[i];
    r.sensor = glm::vec3(ps);
    r.world = glm::dvec3(s2w * glm::dvec4(ps, 1.0));
    r.range = h.t_depth;
    const bool sem = (h.flags & RAYCAST_FLAG_SEM) != 0;
    r.class_id = sem ? static_cast<uint8_t>(h.sem_class) : uint8_t{0};
    r.instance = sem ? static_cast<uint16_t>(h.sem_instance) : uint16_t{0};
    const int axis = t > 0.0 ? lidar_entry_axis(r.world, grid_origin, voxel_size) : -1;
    r.intensity = sem ? lidar_intensity(r.class_id, axis, R * dirs[i]) : 0.0f;
    r.ring = static_cast<uint16_t>(i / m.columns);
    r.column = static_cast<uint16_t>(i % m.columns);
    s.range[i] = r.range;
    s.returns.push_back(r);
  }
  return s;
}

LidarCaster::LidarCaster(gpu::Context& ctx, const LidarModel& model)
    : ctx_(ctx),
      model_(validated(model)),
      dirs_(lidar_directions(model_)),
      caster_(ctx),
      hits_(ctx, std::max<uint64_t>(1, model_.rays()) * sizeof(shader::RaycastHit), gpu::MemoryUsage::DeviceLocal,
            "lidar-hits") {
  if (model_.rays() > UINT32_MAX / 2) throw std::invalid_argument("lidar: too many rays per sweep");
}

LidarScan LidarCaster::cast(const RaycastWorld& w, const glm::dmat4& s2w) {
  auto t0 = Clock::now();
  const GpuRayBatch batch = caster_.upload_rays(w, lidar_rays(dirs_, s2w));
  upload_s += seconds_since(t0);
  t0 = Clock::now();
  const RaycastOptions opts = lidar_raycast_options(model_, w.gpu.voxel_size);
  ctx_.submit_and_wait([&](gpu::CommandList& cmd) { caster_.record_rays(cmd, w, batch, opts, hits_); });
  cast_s += seconds_since(t0);
  t0 = Clock::now();
  const std::vector<shader::RaycastHit> hits = gpu::download_vector<shader::RaycastHit>(ctx_, hits_, batch.count);
  download_s += seconds_since(t0);
  t0 = Clock::now();
  LidarScan s = lidar_scan_from_hits(model_, dirs_, s2w, hits, w.gpu.origin, w.gpu.voxel_size);
  post_s += seconds_since(t0);
  return s;
}

}  // namespace icube::render

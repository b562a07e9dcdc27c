// `icube eval` measures; see package_eval.h.
#include "lift/package_eval.h"

#include "lift/image_metrics.h"
#include "lift/lift_frames.h"
#include "render/buffers/frame_scene.h"
#include "render/buffers/overlay_world.h"
#include "render/lidar/lidar_sequence.h"
#include "scene/atomic_file.h"
#include "scene/input_error.h"
#include "scene/package_check.h"
#include "scene/package_layout.h"
#include "scene/png_read.h"
#include "scene/png_write.h"
#include "splat/lidar_gaussian_sequence.h"
#include "splat/lidar_gaussians_gpu.h"
#include "world/car_mesh.h"
#include "world/npy.h"
#include "world/semantics.h"
#include "world/world_file.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <map>
#include <set>
#include <unordered_map>

namespace icube::lift {

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

constexpr std::array<uint8_t, 3> kMarkingRgb = {255, 217, 47};  // palette entry 5: CURB, LANE_MARKER (§4)
constexpr double kMapSampleStep = 0.25;                          // metres between map samples
constexpr double kMinMapDepth = 0.5;

// The Stage-2 clip folder of the package (buffers/<clip>/ holding semantic_buffer/).
fs::path clip_folder(const scene::PackageLayout& pkg) {
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(pkg.buffers(), ec))
    if (e.is_directory() && fs::is_directory(e.path() / "semantic_buffer")) return e.path();
  throw scene::InputError(pkg.buffers().string(), "", "no clip folder with semantic_buffer/ (the package is partial)");
}

std::vector<size_t> read_key_frames(const fs::path& report_path, size_t frames) {
  const std::string text = scene::read_file(report_path.string());
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(text);
  } catch (const std::exception& e) {
    throw scene::InputError(report_path.string(), "", std::string("not JSON: ") + scene::printable(e.what(), 100));
  }
  if (!j.contains("key_frames") || !j["key_frames"].is_array())
    throw scene::InputError(report_path.string(), "/key_frames", "missing");
  std::vector<size_t> keys;
  for (const auto& k : j["key_frames"]) {
    if (!k.is_number_unsigned() || k.get<size_t>() >= frames)
      throw scene::InputError(report_path.string(), "/key_frames", "not frame numbers below " + std::to_string(frames));
    keys.push_back(k.get<size_t>());
  }
  return keys;
}

// Map polylines sampled every kMapSampleStep metres (the last point included).
std::vector<glm::dvec3> sample_polyline(const std::vector<glm::dvec3>& pts) {
  std::vector<glm::dvec3> out;
  for (size_t i = 0; i + 1 < pts.size(); ++i) {
    const double len = glm::length(pts[i + 1] - pts[i]);
    const int n = std::max(1, int(std::ceil(len / kMapSampleStep)));
    for (int k = 0; k < n; ++k) out.push_back(pts[i] + (pts[i + 1] - pts[i]) * (double(k) / double(n)));
  }
  if (!pts.empty()) out.push_back(pts.back());
  return out;
}

// Map segments (road edges and lane lines) in the ground plane, bucketed in kCell-metre cells, and
// crosswalk polygons: the ground distance from a point to the nearest painted map feature.
class MapGroundIndex {
 public:
  static constexpr double kCell = 2.0, kReach = 6.0;  // distances beyond kReach are reported as kReach

  explicit MapGroundIndex(const scene::Map& m) {
    auto add = [&](const std::vector<glm::dvec3>& pts) {
      for (size_t i = 0; i + 1 < pts.size(); ++i) {
        const glm::dvec2 a(pts[i]), b(pts[i + 1]);
        const size_t id = segs_.size();
        segs_.push_back({a, b});
        const glm::ivec2 lo = cell(glm::min(a, b)), hi = cell(glm::max(a, b));
        for (int y = lo.y; y <= hi.y; ++y)
          for (int x = lo.x; x <= hi.x; ++x) grid_[key(x, y)].push_back(uint32_t(id));
      }
    };
    for (const auto& e : m.road_edges) add(e.points);
    for (const auto& l : m.road_lines) add(l.points);
    for (const auto& c : m.crosswalks) {
      std::vector<glm::dvec2> poly;
      for (const glm::dvec3& p : c.points) poly.emplace_back(p);
      if (poly.size() >= 3) crosswalks_.push_back(std::move(poly));
    }
  }

  double distance(const glm::dvec2& p) const {
    for (const auto& poly : crosswalks_)
      if (inside(poly, p)) return 0.0;
    double best = kReach;
    const glm::ivec2 c = cell(p);
    const int r = int(std::ceil(kReach / kCell));
    for (int y = c.y - r; y <= c.y + r; ++y)
      for (int x = c.x - r; x <= c.x + r; ++x) {
        const auto it = grid_.find(key(x, y));
        if (it == grid_.end()) continue;
        for (uint32_t id : it->second) {
          const glm::dvec2 a = segs_[id].first, ab = segs_[id].second - a;
          const double len2 = glm::dot(ab, ab);
          const double t = len2 > 0.0 ? std::clamp(glm::dot(p - a, ab) / len2, 0.0, 1.0) : 0.0;
          best = std::min(best, glm::length(p - (a + t * ab)));
        }
      }
    return best;
  }

 private:
  static glm::ivec2 cell(const glm::dvec2& p) { return glm::ivec2(glm::floor(p / kCell)); }
  static uint64_t key(int x, int y) { return (uint64_t(uint32_t(x)) << 32) | uint32_t(y); }
  static bool inside(const std::vector<glm::dvec2>& poly, const glm::dvec2& p) {
    bool in = false;
    for (size_t i = 0, j = poly.size() - 1; i < poly.size(); j = i++)
      if ((poly[i].y > p.y) != (poly[j].y > p.y) &&
          p.x < poly[j].x + (p.y - poly[j].y) * (poly[i].x - poly[j].x) / (poly[i].y - poly[j].y))
        in = !in;
    return in;
  }
  std::vector<std::pair<glm::dvec2, glm::dvec2>> segs_;
  std::unordered_map<uint64_t, std::vector<uint32_t>> grid_;
  std::vector<std::vector<glm::dvec2>> crosswalks_;
};

bool is_ground_class(uint8_t c) {
  using SC = world::SemanticClass;
  for (SC g : {SC::Curb, SC::Road, SC::LaneMarker, SC::OtherGround, SC::Walkable, SC::Sidewalk})
    if (c == uint8_t(g)) return true;
  return false;
}

struct Projected {
  int u = 0, v = 0;
  double z = 0.0;
  bool in = false;  // inside the image, in front, within depth range
};

struct Projector {
  glm::dmat4 w2c;
  render::PinholeIntrinsics K;
  double offset = 0.0, max_depth = 40.0;
  Projected operator()(const glm::dvec3& p) const {
    const glm::dvec4 c = w2c * glm::dvec4(p, 1.0);
    Projected q;
    q.z = c.z;
    if (!(c.z >= kMinMapDepth && c.z <= max_depth)) return q;
    const double u = K.fx * c.x / c.z + K.cx - offset, v = K.fy * c.y / c.z + K.cy - offset;
    if (!(u > -0.5 && v > -0.5 && u < double(K.width) - 0.5 && v < double(K.height) - 0.5)) return q;
    q.u = int(std::lround(u));
    q.v = int(std::lround(v));
    q.u = std::clamp(q.u, 0, int(K.width) - 1);
    q.v = std::clamp(q.v, 0, int(K.height) - 1);
    q.in = true;
    return q;
  }
};

std::vector<float> read_depth(const fs::path& path, uint32_t W, uint32_t H) {
  const world::NpyArray a = world::read_npy(path.string());
  if (a.dtype != world::npy_dtype_of<float>() || a.shape.size() != 2 || a.shape[0] != H || a.shape[1] != W)
    throw scene::InputError(path.string(), "", "expected float32 [" + std::to_string(H) + ", " + std::to_string(W) + "]");
  return a.values<float>();
}

// Nearest-rank percentile q of a sorted, non-empty set.
double nearest_rank(const std::vector<double>& sorted, double q) {
  const size_t rank = size_t(std::max(1.0, std::ceil(q * double(sorted.size()))));
  return sorted[std::min(sorted.size(), rank) - 1];
}

LidarStats lidar_stats(const std::vector<double>& signed_err, uint64_t rays, uint64_t both, uint64_t vo, uint64_t go) {
  LidarStats s;
  s.rays = rays;
  s.both = both;
  s.voxel_only = vo;
  s.gaussian_only = go;
  if (signed_err.empty()) return s;
  double sum = 0.0;
  std::vector<double> a;
  a.reserve(signed_err.size());
  for (double e : signed_err) sum += e, a.push_back(std::fabs(e));
  std::sort(a.begin(), a.end());
  s.p50 = nearest_rank(a, 0.5);
  s.p90 = nearest_rank(a, 0.9);
  s.p99 = nearest_rank(a, 0.99);
  s.mean_signed = sum / double(signed_err.size());
  return s;
}

}  // namespace

DistanceStats distance_stats(std::vector<double> v, double tolerance) {
  DistanceStats s;
  s.samples = v.size();
  if (v.empty()) return s;
  std::sort(v.begin(), v.end());
  s.median = nearest_rank(v, 0.5);
  s.p90 = nearest_rank(v, 0.9);
  double sum = 0.0;
  size_t within = 0;
  for (double d : v) sum += d, within += d <= tolerance ? 1 : 0;
  s.mean = sum / double(v.size());
  s.within = double(within) / double(v.size());
  return s;
}

namespace {

// What the evaluations read from the package once.
struct PackageContents {
  scene::PackageLayout pkg;
  std::string frames_dir;
  render::FramesMeta meta;
  std::set<size_t> keys;  // the key frames
  splat::SplatScene gs;
  splat::SkyImage sky;
};

// Novel views at T+offset of every key frame T and spread held-out frames, rendered from the Gaussians.
void evaluate_novel_views(gpu::Context& ctx, const PackageContents& c, const PackageEvalOptions& o, PackageEval& ev) {
  const auto t0 = Clock::now();
  const render::FramesMeta& meta = c.meta;
  const size_t n = meta.poses.size();
  const std::set<size_t>& keys = c.keys;
  const splat::SplatScene& gs = c.gs;
  std::map<size_t, size_t> wanted;  // frame -> index in ev.rendered (filled below)
  for (int off : o.offsets)
    for (size_t T : ev.key_frames)
      if (off > 0 && T + size_t(off) < n && !keys.count(T + size_t(off))) wanted[T + size_t(off)] = 0;
  std::vector<size_t> held;
  for (size_t f = 0; f < n; ++f)
    if (!keys.count(f)) held.push_back(f);
  std::vector<size_t> spread;
  const size_t m = std::min(o.max_heldout, held.size());
  for (size_t i = 0; i < m; ++i) spread.push_back(held[(2 * i + 1) * held.size() / (2 * m)]);
  for (size_t f : spread) wanted[f] = 0;
  if (!wanted.empty()) {
    HeldOutRenderer renderer(ctx, gs, c.sky, meta.pixels);
    size_t done = 0;
    for (auto& [f, idx] : wanted) {
      idx = ev.rendered.size();
      ev.rendered.push_back(renderer.evaluate(c.frames_dir, meta, f));
      if (o.progress) o.progress("novel views", ++done, wanted.size());
    }
  }
  auto make_row = [&](const std::string& label, int off, const std::vector<size_t>& frames, size_t skipped) {
    NovelViewRow r;
    r.label = label;
    r.offset = off;
    r.skipped_key_frames = skipped;
    for (size_t f : frames) {
      const EvalFrame& e = ev.rendered[wanted.at(f)];
      r.psnr += e.psnr;
      r.ssim += e.ssim;
      ++r.frames;
      if (e.dynamic_pixels > 0 && gs.has_objects()) r.psnr_dynamic += e.psnr_dynamic, ++r.dynamic_frames;
    }
    if (r.frames) r.psnr /= double(r.frames), r.ssim /= double(r.frames);
    if (r.dynamic_frames) r.psnr_dynamic /= double(r.dynamic_frames);
    return r;
  };
  for (int off : o.offsets) {
    std::vector<size_t> fs_;
    size_t skipped = 0;
    for (size_t T : ev.key_frames) {
      if (off <= 0 || T + size_t(off) >= n) continue;
      if (keys.count(T + size_t(off))) ++skipped;
      else fs_.push_back(T + size_t(off));
    }
    ev.novel.push_back(make_row("T+" + std::to_string(off), off, fs_, skipped));
  }
  if (!spread.empty()) ev.novel.push_back(make_row("held-out", 0, spread, 0));
  // Images are kept for the (up to 4, evenly spread) frames eval.png shows.
  const size_t shown = std::min<size_t>(4, ev.rendered.size());
  std::set<size_t> keep;
  for (size_t i = 0; i < shown; ++i) keep.insert((2 * i + 1) * ev.rendered.size() / (2 * shown));
  for (size_t i = 0; i < ev.rendered.size(); ++i)
    if (!keep.count(i)) ev.rendered[i].rendered_rgb = {}, ev.rendered[i].reference_rgb = {};
  ev.seconds_novel = seconds_since(t0);
}

// The map drawn into the frames against their paint, and the paint's ground points against the map.
void evaluate_map_alignment(const PackageContents& c, const scene::Scene& sc, const world::VoxelGrid& world,
                            const PackageEvalOptions& o, PackageEval& ev) {
  const auto t0 = Clock::now();
  const fs::path clip = clip_folder(c.pkg);
  const render::FramesMeta& meta = c.meta;
  const size_t n = meta.poses.size();
  // Map heights against the world's ground: a map's z and the prior's road surface can differ (a
  // Waymo map's elevation model), which would shift every sample in the image without any horizontal
  // misalignment. The offset of each sample to the top face of the first ground-class voxel of its
  // column within 2 m is measured, and all samples move by the median offset (one number: the
  // per-sample surface is the road's or the curb's, which the measure is about).
  std::vector<std::vector<glm::dvec3>> edges, lines;
  for (const auto& e : sc.map.road_edges) edges.push_back(sample_polyline(e.points));
  for (const auto& l : sc.map.road_lines) lines.push_back(sample_polyline(l.points));
  std::vector<double> ground_offsets;
  for (const auto* layer : {&edges, &lines})
    for (const auto& pl : *layer)
      for (const glm::dvec3& p : pl) {
        const double vs = world.voxel_size();
        const glm::ivec3 top = world.world_to_ijk(p + glm::dvec3(0.0, 0.0, 2.0));
        for (int k = 0; k <= int(std::ceil(4.0 / vs)); ++k) {
          const glm::ivec3 ijk(top.x, top.y, top.z - k);
          if (!is_ground_class(world.get(ijk).class_id)) continue;
          ground_offsets.push_back(world.ijk_to_world(ijk).z + 0.5 * vs - p.z);
          break;
        }
      }
  if (!ground_offsets.empty()) {
    std::vector<double> sorted = ground_offsets, abs_offsets;
    std::nth_element(sorted.begin(), sorted.begin() + ptrdiff_t(sorted.size() / 2), sorted.end());
    ev.map.ground_offset_median_signed = sorted[sorted.size() / 2];
    for (double d : ground_offsets) abs_offsets.push_back(std::fabs(d - ev.map.ground_offset_median_signed));
    ev.map.ground_offset = distance_stats(abs_offsets, 0.2);
    for (auto* layer : {&edges, &lines})
      for (auto& pl : *layer)
        for (glm::dvec3& p : pl) p.z += ev.map.ground_offset_median_signed;
  }
  std::vector<double> d_edges, d_lines, d_marks;
  const MapGroundIndex ground(sc.map);
  const uint32_t W = meta.width, H = meta.height;
  size_t overlay_samples = 0;  // the overlay shows the frame with the most visible map samples
  for (size_t f = 0; f < n; ++f) {
    const std::string name = render::frame_file_name(f);
    const fs::path sem_path = clip / "semantic_buffer" / name;
    const scene::Image8 sem = scene::read_png(sem_path.string(), 3);
    if (uint32_t(sem.width) != W || uint32_t(sem.height) != H)
      throw scene::InputError(sem_path.string(), "", "size differs from the frames'");
    const std::vector<float> depth =
        read_depth(clip / "depth" / (name.substr(0, name.size() - 4) + ".npy"), W, H);
    std::vector<uint8_t> marking(size_t(W) * H);
    for (size_t p = 0; p < marking.size(); ++p)
      marking[p] = sem.pixels[3 * p] == kMarkingRgb[0] && sem.pixels[3 * p + 1] == kMarkingRgb[1] &&
                   sem.pixels[3 * p + 2] == kMarkingRgb[2];
    const std::vector<float> to_marking = distance_transform(marking, W, H);
    Projector proj{glm::inverse(meta.poses[f]), meta.K, render::pixel_offset(meta.pixels), o.max_map_depth};
    std::vector<std::pair<Projected, bool>> drawn;  // for the overlay
    std::vector<size_t> far_paint;                  // overlay: paint pixels beyond the paint tolerance
    auto visit = [&](const std::vector<std::vector<glm::dvec3>>& layer, std::vector<double>& out) {
      for (const auto& pl : layer) {
        for (const glm::dvec3& p : pl) {
          Projected q = proj(p);
          if (q.in) {
            const double d = double(depth[size_t(q.v) * W + size_t(q.u)]);
            q.in = d > 0.0 && q.z <= d + std::max(0.5, 0.05 * q.z);
          }
          if (q.in) {
            const double dist = double(to_marking[size_t(q.v) * W + size_t(q.u)]);
            out.push_back(std::isinf(dist) ? double(W + H) : dist);
            drawn.emplace_back(q, dist <= o.map_tolerance_px);
          }
        }
      }
    };
    visit(edges, d_edges);
    visit(lines, d_lines);
    // Paint → map: each paint pixel's ground point (depth along its ray) to the nearest map feature.
    const render::Camera cam = frame_camera(meta, f);
    for (uint32_t v = 0; v < H; ++v)
      for (uint32_t u = 0; u < W; ++u) {
        const size_t p = size_t(v) * W + u;
        if (!marking[p] || !(depth[p] > 0.0f) || double(depth[p]) > o.max_map_depth) continue;
        const glm::dvec3 dc = render::camera_ray_dir_cam(meta.K, u, v, meta.pixels);
        const glm::dvec3 pw = glm::dvec3(cam.c2w * glm::dvec4(dc * (double(depth[p]) / dc.z), 1.0));
        d_marks.push_back(ground.distance(glm::dvec2(pw)));
        if (d_marks.back() > o.paint_tolerance_m) far_paint.push_back(p);
      }
    if (drawn.size() > overlay_samples) {
      // Paint beyond the paint tolerance magenta; map samples as 3x3 dots, green within the
      // image tolerance of paint, red beyond.
      overlay_samples = drawn.size();
      ev.map_overlay = sem.pixels;
      ev.map_overlay_frame = f;
      for (size_t p : far_paint) ev.map_overlay[3 * p] = 255, ev.map_overlay[3 * p + 1] = 0, ev.map_overlay[3 * p + 2] = 255;
      for (const auto& [q, ok] : drawn)
        for (int dy = -1; dy <= 1; ++dy)
          for (int dx = -1; dx <= 1; ++dx) {
            const int x = q.u + dx, y = q.v + dy;
            if (x < 0 || y < 0 || x >= int(W) || y >= int(H)) continue;
            uint8_t* px = &ev.map_overlay[(size_t(y) * W + size_t(x)) * 3];
            px[0] = ok ? 0 : 230, px[1] = ok ? 160 : 0, px[2] = 0;
          }
    }
    if (o.progress) o.progress("map", f + 1, n);
  }
  ev.map.frames = n;
  ev.map.road_edges = distance_stats(d_edges, o.map_tolerance_px);
  ev.map.lane_lines = distance_stats(d_lines, o.map_tolerance_px);
  ev.map.marking_to_map = distance_stats(d_marks, o.paint_tolerance_m);
  ev.seconds_map = seconds_since(t0);
}

// LiDAR sweeps of the voxels (with each frame's cars) against sweeps of the Gaussians from the same poses.
void evaluate_lidar_agreement(gpu::Context& ctx, const PackageContents& c, const scene::Scene& sc,
                              const world::VoxelGrid& world, const PackageEvalOptions& o, PackageEval& ev) {
  const auto t0 = Clock::now();
  const render::FramesMeta& meta = c.meta;
  const size_t n = meta.poses.size();
  const uint32_t W = meta.width, H = meta.height;
  std::vector<size_t> lidar_frames;
  for (size_t f = 0; f < n; ++f)
    if (f < meta.source_time_indices.size() && meta.source_time_indices[f] >= 0 &&
        size_t(meta.source_time_indices[f]) < sc.ego.size() && sc.ego[size_t(meta.source_time_indices[f])].valid)
      lidar_frames.push_back(f);
  if (o.lidar_frames == 0) {
    ev.lidar.note = "not asked for (--lidar-frames 0)";
  } else if (lidar_frames.empty()) {
    ev.lidar.note = "no frame has a scene time with a valid ego pose (a --route or imported trajectory)";
  } else {
    std::vector<size_t> pick;
    const size_t k = std::min(o.lidar_frames, lidar_frames.size());
    for (size_t i = 0; i < k; ++i) pick.push_back(lidar_frames[(2 * i + 1) * lidar_frames.size() / (2 * k)]);
    render::Trajectory traj;
    for (size_t f : pick) {
      const int t = meta.source_time_indices[f];
      traj.c2w.push_back(sc.ego[size_t(t)].ego_to_world * o.lidar.sensor_to_ego);
      traj.frame_index.push_back(int(f));
      traj.time_index.push_back(t);
    }
    // Voxels: the world with each frame's cars, as `icube lidar` casts it.
    const world::TriangleMesh mesh = world::builtin_car_mesh();
    std::vector<std::vector<float>> voxel_range;
    {
      const world::VoxelGrid static_world = render::make_static_world(world, sc, std::max(0, traj.time_index[0]), mesh);
      render::OverlayWorld overlay(ctx, static_world);
      render::LidarSequenceOptions so;
      so.on_frame = [&](const render::LidarScan& s) { voxel_range.push_back(s.range); };
      render::cast_lidar_sequence(ctx, overlay, &sc, mesh, o.lidar, traj, so);
    }
    splat::LidarGaussiansGpu caster(ctx, o.lidar);
    const std::vector<glm::dvec3>& dirs = caster.directions();
    std::vector<double> err_all, err_view;
    uint64_t rays = 0, both = 0, vo = 0, go = 0, rays_v = 0, both_v = 0, vo_v = 0, go_v = 0;
    std::vector<render::LidarScan> gaussian_scans;
    splat::LidarGaussianSequenceOptions so;
    for (const size_t f : pick) so.scene_frames.push_back(splat_frame_of(meta, f));
    so.on_frame = [&](const render::LidarScan& s) { gaussian_scans.push_back(s); };
    splat::cast_lidar_gaussian_sequence(caster, c.gs, traj, so);
    for (size_t i = 0; i < pick.size(); ++i) {
      const render::LidarScan& s = gaussian_scans[i];
      const glm::dmat4 w2c = glm::inverse(meta.poses[pick[i]]);
      const glm::dmat3 s2w(traj.c2w[i]);
      for (size_t r = 0; r < s.range.size(); ++r) {
        const glm::dvec3 dc = glm::dmat3(w2c) * (s2w * dirs[r % dirs.size()]);
        bool in_view = false;
        if (dc.z > 1e-6) {
          const double u = meta.K.fx * dc.x / dc.z + meta.K.cx, v = meta.K.fy * dc.y / dc.z + meta.K.cy;
          in_view = u >= 0.0 && v >= 0.0 && u < double(W) && v < double(H);
        }
        const float rv = voxel_range[i][r], rg = s.range[r];
        ++rays;
        rays_v += in_view;
        if (rv > 0.0f && rg > 0.0f) {
          ++both;
          err_all.push_back(double(rg) - double(rv));
          if (in_view) ++both_v, err_view.push_back(double(rg) - double(rv));
        } else if (rv > 0.0f) {
          ++vo, vo_v += in_view;
        } else if (rg > 0.0f) {
          ++go, go_v += in_view;
        }
      }
      if (o.progress) o.progress("lidar", i + 1, pick.size());
    }
    ev.lidar.frames = pick.size();
    ev.lidar.all = lidar_stats(err_all, rays, both, vo, go);
    ev.lidar.in_view = lidar_stats(err_view, rays_v, both_v, vo_v, go_v);
  }
  ev.seconds_lidar = seconds_since(t0);
}

}  // namespace

PackageEval evaluate_package(gpu::Context& ctx, const std::string& package, const scene::Scene& sc,
                             const PackageEvalOptions& o) {
  const scene::PackageLayout pkg(package);
  const scene::PackageCheck check = scene::check_package(package, false);
  if (!check.complete) throw std::runtime_error(check.problem);
  PackageEval ev;
  ev.package = package;
  PackageContents c{pkg, pkg.frames().string(), {}, {}, {}, {}};
  c.meta = render::read_frames_meta(c.frames_dir);
  const render::FramesMeta& meta = c.meta;
  const size_t n = meta.poses.size();
  ev.frames = n;
  ev.width = meta.width;
  ev.height = meta.height;
  ev.key_frames = read_key_frames(pkg.lift_report(), n);
  c.keys = std::set<size_t>(ev.key_frames.begin(), ev.key_frames.end());
  c.gs = splat::read_splat_scene(pkg.splat_scene().string());
  const splat::SplatScene& gs = c.gs;
  if (gs.has_objects())
    for (size_t f = 0; f < n; ++f)
      if (splat_frame_of(meta, f) >= gs.frames())
        throw scene::InputError(pkg.splat_scene().string(), "/frames",
                                std::to_string(gs.frames()) + " frames, but package frame " + std::to_string(f) +
                                    " needs frame " + std::to_string(splat_frame_of(meta, f)));
  c.sky = splat::read_sky_png(pkg.sky().string());

  evaluate_novel_views(ctx, c, o, ev);
  const world::VoxelGrid world = world::load_world(pkg.world().string());
  evaluate_map_alignment(c, sc, world, o, ev);
  evaluate_lidar_agreement(ctx, c, sc, world, o, ev);
  return ev;
}

void write_package_eval(const std::string& dir, const PackageEval& e, const PackageEvalOptions& o) {
  const fs::path out(dir);
  nlohmann::ordered_json j;
  j["format"] = "icube-eval";
  j["version"] = 1;
  j["package"] = e.package;
  j["frames"] = e.frames;
  j["key_frames"] = e.key_frames;
  nlohmann::ordered_json nv = nlohmann::ordered_json::array();
  for (const NovelViewRow& r : e.novel)
    nv.push_back({{"label", r.label}, {"offset", r.offset}, {"frames", r.frames},
                  {"skipped_key_frames", r.skipped_key_frames}, {"psnr_db", r.psnr}, {"ssim", r.ssim},
                  {"dynamic_frames", r.dynamic_frames}, {"psnr_dynamic_db", r.psnr_dynamic}});
  j["novel_views"] = nv;
  nlohmann::ordered_json per = nlohmann::ordered_json::array();
  for (const EvalFrame& f : e.rendered)
    per.push_back({{"frame", f.frame}, {"psnr_db", f.psnr}, {"ssim", f.ssim}, {"pixels", f.pixels},
                   {"psnr_dynamic_db", f.psnr_dynamic}, {"dynamic_pixels", f.dynamic_pixels}});
  j["frames_evaluated"] = per;
  auto dist = [](const DistanceStats& s) {
    return nlohmann::ordered_json{{"samples", s.samples}, {"median_px", s.median}, {"p90_px", s.p90},
                                  {"mean_px", s.mean}, {"within_tolerance", s.within}};
  };
  j["map_alignment"] = {{"frames", e.map.frames},
                        {"ground_offset_m", {{"samples", e.map.ground_offset.samples},
                                             {"median_applied", e.map.ground_offset_median_signed},
                                             {"spread_p90", e.map.ground_offset.p90}}},
                        {"tolerance_px", o.map_tolerance_px},
                        {"max_depth_m", o.max_map_depth},
                        {"road_edges_to_buffer", dist(e.map.road_edges)},
                        {"lane_lines_to_buffer", dist(e.map.lane_lines)},
                        {"paint_tolerance_m", o.paint_tolerance_m},
                        {"buffer_paint_to_map_m", dist(e.map.marking_to_map)}};
  auto lid = [](const LidarStats& s) {
    return nlohmann::ordered_json{{"rays", s.rays},         {"both", s.both},           {"voxel_only", s.voxel_only},
                                  {"gaussian_only", s.gaussian_only}, {"abs_err_p50_m", s.p50}, {"abs_err_p90_m", s.p90},
                                  {"abs_err_p99_m", s.p99}, {"mean_signed_err_m", s.mean_signed}};
  };
  j["lidar_agreement"] = {{"frames", e.lidar.frames}, {"all_rays", lid(e.lidar.all)}, {"in_camera_view", lid(e.lidar.in_view)}};
  if (!e.lidar.note.empty()) j["lidar_agreement"]["note"] = e.lidar.note;
  scene::write_file_atomic((out / "eval.json").string(), j.dump(1) + "\n");

  // eval.png: up to 4 evaluated frames (reference | rendered | |error| x4), then the map overlay.
  const size_t W = e.width, H = e.height;
  std::vector<size_t> show;
  for (size_t i = 0; i < e.rendered.size(); ++i)
    if (!e.rendered[i].rendered_rgb.empty()) show.push_back(i);
  const size_t rows = show.size() + (e.map_overlay.empty() ? 0 : 1);
  if (rows == 0) return;
  const size_t SW = 3 * W;
  std::vector<uint8_t> img(SW * H * rows * 3, 0);
  auto put = [&](size_t row, size_t col, const std::vector<uint8_t>& rgb) {
    for (size_t y = 0; y < H; ++y)
      std::copy_n(&rgb[y * W * 3], W * 3, &img[((row * H + y) * SW + col * W) * 3]);
  };
  for (size_t r = 0; r < show.size(); ++r) {
    const EvalFrame& f = e.rendered[show[r]];
    put(r, 0, f.reference_rgb);
    put(r, 1, f.rendered_rgb);
    std::vector<uint8_t> err(W * H * 3);
    for (size_t p = 0; p < W * H; ++p) {
      int m = 0;
      for (int c = 0; c < 3; ++c)
        m = std::max(m, std::abs(int(f.rendered_rgb[3 * p + size_t(c)]) - int(f.reference_rgb[3 * p + size_t(c)])));
      const uint8_t v = uint8_t(std::min(255, 4 * m));
      err[3 * p] = err[3 * p + 1] = err[3 * p + 2] = v;
    }
    put(r, 2, err);
  }
  if (!e.map_overlay.empty()) put(show.size(), 0, e.map_overlay);
  scene::write_file_atomic((out / "eval.png").string(),
                           scene::encode_png(img.data(), int(SW), int(H * rows), 3));
}

}  // namespace icube::lift

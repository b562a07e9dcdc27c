// Stage-2 clip folder writer; see stage2_writer.h.
#include "render/buffers/stage2_writer.h"

#include "render/buffers/frame_scene.h"
#include "render/buffers/tar_archive.h"
#include "scene/atomic_file.h"
#include "scene/frames.h"
#include "scene/png_write.h"
#include "video/mp4_writer.h"
#include "world/npy.h"

#include <algorithm>
#include <atomic>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <mutex>
#include <sstream>
#include <thread>

namespace icube::render {

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

std::string frame_id(int i) {
  char b[32];
  std::snprintf(b, sizeof b, "%06d", i);
  return b;
}

// Shortest text that reads back to the same double.
std::string num(double v) {
  if (!std::isfinite(v)) return "null";
  char b[64];
  const auto r = std::to_chars(b, b + sizeof b, v);
  return std::string(b, r.ptr);
}

std::string matrix_json(const glm::dmat4& m) {
  std::string s = "[";
  for (int r = 0; r < 4; ++r) {
    s += r ? ", [" : "[";
    for (int c = 0; c < 4; ++c) {
      if (c) s += ", ";
      s += num(m[c][r]);
    }
    s += "]";
  }
  return s + "]";
}

std::string json_escape(const std::string& in) {
  std::string s;
  for (char c : in) {
    if (c == '"' || c == '\\') s += '\\';
    if (static_cast<unsigned char>(c) < 32) continue;
    s += c;
  }
  return s;
}

std::vector<double> row_major(const glm::dmat4& m) {
  std::vector<double> v(16);
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) v[static_cast<size_t>(4 * r + c)] = m[c][r];
  return v;
}

// Upstream saves poses as float32 (`.float()` before the tar).
std::vector<float> row_major_f32(const glm::dmat4& m) {
  std::vector<float> v(16);
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) v[static_cast<size_t>(4 * r + c)] = static_cast<float>(m[c][r]);
  return v;
}

std::string png_rgb(const std::vector<uint8_t>& rgb, uint32_t w, uint32_t h) {
  return scene::encode_png(rgb.data(), static_cast<int>(w), static_cast<int>(h), 3);
}

// Runs fn(i) for i in [0, n) on `threads` threads; rethrows the first exception.
template <class F>
void parallel_for(size_t n, unsigned threads, F&& fn) {
  std::atomic<size_t> next{0};
  std::exception_ptr err;
  std::mutex mu;
  auto worker = [&] {
    while (true) {
      const size_t i = next.fetch_add(1);
      if (i >= n) return;
      try {
        fn(i);
      } catch (...) {
        std::lock_guard<std::mutex> lock(mu);
        if (!err) err = std::current_exception();
        next = n;
      }
    }
  };
  std::vector<std::thread> pool;
  for (unsigned t = 1; t < threads; ++t) pool.emplace_back(worker);
  worker();
  for (auto& t : pool) t.join();
  if (err) std::rethrow_exception(err);
}

}  // namespace

glm::dmat4 world_to_voxel_world(const glm::dmat4& c2w0) { return glm::inverse(scene::opencv_to_flu(c2w0)); }

const char* object_info_mode_name(ObjectInfoMode m) {
  return m == ObjectInfoMode::Moving ? "moving" : "observed";
}

std::string dynamic_object_info_json(const scene::Scene* s, int t, const glm::dmat4& w2v, ObjectInfoMode mode) {
  if (!s || t < 0) return "{}";
  std::ostringstream out;
  out << "{";
  bool first = true;
  for (size_t k = 0; k < s->tracks.size(); ++k) {
    const scene::Track& tr = s->tracks[k];
    if (tr.type != scene::ObjectType::Vehicle || scene::is_ego_track(*s, k)) continue;
    const scene::BoxState* b = nullptr;
    size_t source = static_cast<size_t>(t);
    if (mode == ObjectInfoMode::Moving) {
      if (!tr.dynamic) continue;
      b = scene::state_filled(tr, t, &source);
    } else if (static_cast<size_t>(t) < tr.states.size() && tr.states[static_cast<size_t>(t)].valid) {
      b = &tr.states[static_cast<size_t>(t)];
    }
    if (!b) continue;
    out << (first ? "\n  " : ",\n  ");
    first = false;
    out << "\"" << tr.id << "\": {\"object_to_world\": " << matrix_json(w2v * scene::box_to_world(*b))
        << ", \"object_lwh\": [" << num(b->length) << ", " << num(b->width) << ", " << num(b->height)
        << "], \"object_is_moving\": " << (scene::state_moving(tr, source) ? "true" : "false")
        << ", \"object_type\": \"car\", \"object_id_int\": " << tr.instance_id << "}";
  }
  out << (first ? "}" : "\n}");
  return out.str();
}

Stage2Result write_stage2(const GuidanceSequence& seq, const scene::Scene* scene, const glm::dmat4& w2v,
                          const std::string& dir, const Stage2Options& opts) {
  namespace fs = std::filesystem;
  const auto t0 = Clock::now();
  Stage2Result res;
  const std::string& clip = opts.clip;
  const uint32_t W = seq.K.width, H = seq.K.height;
  const size_t nf = seq.frames.size();
  for (const char* sub : {"semantic_buffer", "coordinate_buffer", "coordinate_points", "depth", "depth_vis"})
    fs::create_directories(fs::path(dir) / sub);
  if (opts.normals) fs::create_directories(fs::path(dir) / "normal_buffer");
  std::vector<std::string> depth_png(nf), inst_png(nf);
  const unsigned threads = opts.threads ? opts.threads : std::max(1u, std::thread::hardware_concurrency());
  std::atomic<size_t> files{0};
  parallel_for(nf, threads, [&](size_t f) {
    const GuidanceFrame& fr = seq.frames[f];
    const std::string id = frame_id(static_cast<int>(f));
    const std::vector<uint16_t> cm = depth_centimetres(fr.zdepth);
    depth_png[f] = scene::encode_png_gray16(cm.data(), static_cast<int>(W), static_cast<int>(H));
    inst_png[f] = scene::encode_png_gray16(fr.instance.data(), static_cast<int>(W), static_cast<int>(H));
    scene::write_file_atomic(dir + "/semantic_buffer/" + id + ".png", png_rgb(semantic_rgb(fr, seq.instance_colors), W, H));
    const std::vector<float> pts = coordinate_points(seq.K, fr.zdepth, seq.rel[f], seq.pixels);
    scene::write_file_atomic(dir + "/coordinate_buffer/" + id + ".png",
                             png_rgb(encode_coordinates(pts, fr.zdepth, seq.coordinates), W, H));
    world::write_npy(dir + "/coordinate_points/" + id + ".npy", world::NpyArray::make<float>({H, W, 3}, pts));
    world::write_npy(dir + "/depth/" + id + ".npy", world::NpyArray::make<float>({H, W}, fr.zdepth));
    scene::write_file_atomic(dir + "/depth_vis/" + id + ".png", png_rgb(depth_vis_rgb(fr.zdepth), W, H));
    files += 5;
    if (opts.normals && !fr.normal.empty()) {
      scene::write_file_atomic(dir + "/normal_buffer/" + id + ".png", png_rgb(normal_rgb(fr), W, H));
      ++files;
    }
  });
  TarWriter depth_tar, inst_tar, pose_tar, intr_tar, obj_tar;
  for (size_t f = 0; f < nf; ++f) {
    const std::string base = clip + "." + frame_id(static_cast<int>(f));
    depth_tar.add(base + ".voxel_depth_100.front.png", std::move(depth_png[f]));
    inst_tar.add(base + ".instance_buffer.front.png", std::move(inst_png[f]));
    pose_tar.add(base + ".pose.front.npy",
                 world::npy_to_bytes(world::NpyArray::make<float>({4, 4}, row_major_f32(w2v * seq.trajectory.c2w[f]))));
    obj_tar.add(base + ".dynamic_object_info.json",
                dynamic_object_info_json(scene, seq.trajectory.time_index[f], w2v, opts.object_info) + "\n");
  }
  intr_tar.add(clip + ".intrinsic.front.npy",
               world::npy_to_bytes(world::NpyArray::make<double>(
                   {6}, std::vector<double>{seq.K.fx, seq.K.fy, seq.K.cx, seq.K.cy, static_cast<double>(W),
                                            static_cast<double>(H)})));
  depth_tar.write(dir + "/voxel_depth_100_480p_front.tar");
  inst_tar.write(dir + "/instance_buffer_480p_front.tar");
  pose_tar.write(dir + "/pose.tar");
  intr_tar.write(dir + "/intrinsic.tar");
  obj_tar.write(dir + "/dynamic_object_info.tar");
  world::write_npy(dir + "/world_to_voxel_world.npy", world::NpyArray::make<double>({4, 4}, row_major(w2v)));
  files += 6;

  std::ostringstream meta;
  meta << "{\n  \"format\": \"icube-guidance-buffers\",\n  \"version\": 2,\n  \"clip\": \"" << json_escape(clip)
       << "\",\n  \"frames\": " << nf << ",\n  \"intrinsics\": [" << num(seq.K.fx) << ", " << num(seq.K.fy) << ", "
       << num(seq.K.cx) << ", " << num(seq.K.cy) << ", " << W << ", " << H << "],\n  \"pixel_convention\": \""
       << (seq.pixels == PixelConvention::Integer ? "integer" : "centre") << "\",\n  \"coordinate_min\": ["
       << num(seq.coordinates.min.x) << ", " << num(seq.coordinates.min.y) << ", " << num(seq.coordinates.min.z)
       << "],\n  \"coordinate_range\": [" << num(seq.coordinates.range.x) << ", " << num(seq.coordinates.range.y) << ", "
       << num(seq.coordinates.range.z) << "],\n  \"coordinate_samples\": " << seq.coordinates.samples
       << ",\n  \"instance_colors\": {";
  bool first = true;
  for (const auto& [id, c] : seq.instance_colors) {
    meta << (first ? "" : ", ") << "\"" << id << "\": [" << int{c[0]} << ", " << int{c[1]} << ", " << int{c[2]} << "]";
    first = false;
  }
  meta << "},\n  \"object_info\": \"" << object_info_mode_name(opts.object_info)
       << "\",\n  \"source_frame_indices\": [";
  for (size_t f = 0; f < nf; ++f) meta << (f ? ", " : "") << seq.trajectory.frame_index[f];
  meta << "],\n  \"source_time_indices\": [";
  for (size_t f = 0; f < nf; ++f) meta << (f ? ", " : "") << seq.trajectory.time_index[f];
  meta << "]\n}\n";
  scene::write_file_atomic(dir + "/buffers_meta.json", meta.str());
  ++files;
  res.write_s = seconds_since(t0);

  const auto t1 = Clock::now();
  if (!opts.videos) {
    res.notes.push_back("videos disabled: no mp4 written");
  } else {
    video::Mp4Writer sem(dir + "/semantic_buffer_video_480p_front.mp4", W, H, opts.video);
    video::Mp4Writer crd(dir + "/coordinate_buffer_video_480p_front.mp4", W, H, opts.video);
    video::Mp4Writer dep(dir + "/depth_vis_video_480p_front.mp4", W, H, opts.video);
    for (size_t f = 0; f < nf; ++f) {
      const GuidanceFrame& fr = seq.frames[f];
      sem.add_frame(semantic_rgb(fr, seq.instance_colors));
      crd.add_frame(encode_coordinates(coordinate_points(seq.K, fr.zdepth, seq.rel[f], seq.pixels), fr.zdepth,
                                       seq.coordinates));
      dep.add_frame(depth_vis_rgb(fr.zdepth));
    }
    sem.finish();
    crd.finish();
    dep.finish();
    files += 3;
  }
  res.video_s = seconds_since(t1);
  res.files = files;
  return res;
}

}  // namespace icube::render

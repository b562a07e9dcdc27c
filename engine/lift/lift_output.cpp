// The lift's output folder; see lift_output.h.
#include "lift/lift_output.h"

#include "scene/atomic_file.h"
#include "scene/package_layout.h"
#include "scene/png_write.h"
#include "splat/splat_scene.h"

#include <nlohmann/json.hpp>

#include <filesystem>

namespace icube::lift {

nlohmann::ordered_json lift_report(const render::FramesMeta& meta, const LiftFramesResult& r, const LiftFramesOptions& o) {
  nlohmann::ordered_json rep;
  rep["format"] = kLiftReportFormat;
  rep["version"] = 1;
  rep["frames"] = meta.poses.size();
  rep["key_frames"] = r.key_frames;
  rep["options"] = {{"key_every", o.key_every},          {"gaussians_per_cell", o.lift.per_cell},
                    {"cell_sigma", o.lift.cell_sigma},    {"face_gaussians", o.lift.face_gaussians},
                    {"hidden", o.lift.hidden},            {"hidden_radius", o.lift.hidden_radius},
                    {"pixel_frames", o.pixel_frames}};
  rep["samples"] = r.samples;
  rep["sky_samples"] = r.sky_samples;
  rep["gaussians"] = {{"total", r.cloud.size()},           {"surface", r.stats.surface_gaussians},
                      {"hidden", r.stats.hidden_gaussians}, {"seen_faces", r.stats.seen_faces},
                      {"seen_cells", r.stats.seen_cells},   {"pixel", r.pixel.gaussians}};
  rep["midground_pixels"] = {{"total", r.pixel.pixels},
                             {"road_plane", r.pixel.ground},
                             {"world_bounds", r.pixel.backdrop},
                             {"clamped", r.pixel.clamped}};
  nlohmann::ordered_json objs = nlohmann::ordered_json::array();
  for (const splat::SplatObject& obj : r.objects)
    objs.push_back({{"id", obj.id}, {"gaussians", obj.gaussians.size()}, {"file", obj.source}});
  rep["dynamic_samples"] = r.dynamic_samples;
  rep["objects"] = objs;
  nlohmann::ordered_json ev = nlohmann::ordered_json::array();
  for (const EvalFrame& e : r.eval) {
    nlohmann::ordered_json x = {{"frame", e.frame}, {"psnr_db", e.psnr}, {"ssim", e.ssim}, {"pixels", e.pixels}};
    if (e.dynamic_pixels > 0 && !r.objects.empty())
      x["dynamic"] = {{"psnr_db", e.psnr_dynamic}, {"pixels", e.dynamic_pixels}};
    ev.push_back(x);
  }
  rep["held_out"] = ev;
  rep["mean_psnr_db"] = r.mean_psnr();
  return rep;
}

void write_lift_outputs(const std::string& dir_name, const render::FramesMeta& meta, const LiftFramesResult& r,
                        const LiftFramesOptions& o) {
  write_lift_outputs(dir_name, meta, r, lift_report(meta, r, o));
}

void write_lift_outputs(const std::string& dir_name, const render::FramesMeta& meta, const LiftFramesResult& r,
                        const nlohmann::ordered_json& rep) {
  namespace fs = std::filesystem;
  const fs::path dir(dir_name);
  fs::create_directories(dir);
  splat::write_gaussians_ply((dir / scene::PackageLayout::kStaticPly).string(), r.cloud);
  scene::write_file_atomic((dir / scene::PackageLayout::kSky).string(),
                           scene::encode_png(r.sky.rgba.data(), int(r.sky.width), int(r.sky.height), 4));
  nlohmann::ordered_json sj;
  sj["format"] = splat::kSplatSceneFormat;
  sj["version"] = splat::kSplatSceneVersion;
  sj["static"] = scene::PackageLayout::kStaticPly;
  if (!r.objects.empty()) {
    // Each dynamic object's Gaussians in its object frame, and its pose in every frame that has it.
    sj["frames"] = r.splat_frames;
    nlohmann::ordered_json objs = nlohmann::ordered_json::array();
    for (const splat::SplatObject& obj : r.objects) {
      splat::write_gaussians_ply((dir / obj.source).string(), obj.gaussians);
      nlohmann::ordered_json track = nlohmann::ordered_json::array();
      for (size_t f = 0; f < obj.present.size(); ++f) {
        if (!obj.present[f]) continue;
        nlohmann::ordered_json rows = nlohmann::ordered_json::array();
        for (int rr = 0; rr < 4; ++rr)
          rows.push_back({obj.poses[f][0][rr], obj.poses[f][1][rr], obj.poses[f][2][rr], obj.poses[f][3][rr]});
        track.push_back({{"frame", f}, {"object_to_world", rows}});
      }
      objs.push_back({{"id", obj.id}, {"gaussians", obj.source}, {"track", track}});
    }
    sj["objects"] = objs;
  }
  scene::write_file_atomic((dir / scene::PackageLayout::kSplatScene).string(), sj.dump(1) + "\n");

  scene::write_file_atomic((dir / scene::PackageLayout::kLiftReport).string(), rep.dump(1) + "\n");
  if (r.eval.empty()) return;

  const size_t cols = r.eval.size(), W = meta.width, H = meta.height, SW = cols * W;
  std::vector<uint8_t> img(SW * 2 * H * 3, 0);
  for (size_t c = 0; c < cols; ++c) {
    const std::vector<uint8_t>& ref = r.eval[c].reference_rgb;
    for (size_t y = 0; y < H; ++y)
      for (size_t x = 0; x < W; ++x)
        for (size_t k = 0; k < 3; ++k) {
          img[(y * SW + c * W + x) * 3 + k] = ref[(y * W + x) * 3 + k];
          img[((H + y) * SW + c * W + x) * 3 + k] = r.eval[c].rendered_rgb[(y * W + x) * 3 + k];
        }
  }
  scene::write_file_atomic((dir / scene::PackageLayout::kLiftEval).string(), scene::encode_png(img.data(), int(SW), int(2 * H), 3));
}

}  // namespace icube::lift

// Stage 3 with the GSM; see gsm_lift.h.
#include "lift/gsm_lift.h"

#include "lift/dynamic_lift.h"
#include "lift/gsm_depth_support.h"
#include "lift/gsm_gaussians.h"
#include "lift/gsm_lift_inputs.h"
#include "lift/lift_output.h"
#include "nn/gsm/gsm_gpu.h"
#include "nn/gsm/gsm_rays.h"
#include "nn/gsm/gsm_reference.h"
#include "render/buffers/frame_scene.h"
#include "scene/frames.h"
#include "scene/input_error.h"
#include "splat/splat_scene.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <map>
#include <optional>

namespace icube::lift {

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

std::string size_text(uint32_t w, uint32_t h) { return std::to_string(w) + "x" + std::to_string(h); }

int time_index_of(const render::FramesMeta& meta, size_t f) {
  return f < meta.source_time_indices.size() ? std::max(0, meta.source_time_indices[f]) : 0;
}

// The dynamic vehicles of scene state `t` (dynamic_vehicle_states: the official dynamic_object_info),
// boxes in the grid frame, by instance id.
std::vector<GsmObjectBox> object_boxes(const scene::Scene& s, int t, const GsmGridFrame& g) {
  const glm::dmat4 world_to_grid = glm::inverse(g.grid_to_world());
  std::vector<GsmObjectBox> out;
  for (const auto& [id, b] : dynamic_vehicle_states(s, t))
    out.push_back({id, world_to_grid * scene::box_to_world(*b), glm::dvec3(b->length, b->width, b->height)});
  return out;
}

// An input batch of `views_per_element` views per element, H x W, filled by the caller.
nn::GsmInputs empty_inputs(int64_t batch, int64_t views, uint32_t w, uint32_t h, const nn::GsmConfig& c) {
  nn::GsmInputs in;
  in.batch = batch;
  in.views = views;
  in.height = h;
  in.width = w;
  const size_t px = size_t(batch * views) * w * h;
  in.images = nn::CpuTensor({batch, views, int64_t(h), int64_t(w), 3});
  in.masks.assign(px * 4, 1);
  const int64_t P = c.pixel.depth_patch_size > 0 ? c.pixel.depth_patch_size : 16;
  in.depth_patch_keep.assign(size_t(batch * views * (h / P) * (w / P)), 1);
  return in;
}

void put_view(nn::GsmInputs& in, size_t view, const GsmFrame& f) {
  const size_t px = size_t(f.width) * f.height;
  std::copy(f.rgb.begin(), f.rgb.end(), in.images.data.begin() + std::ptrdiff_t(view * px * 3));
}

uint8_t& mask_at(nn::GsmInputs& in, size_t view, size_t p, int ch) {
  return in.masks[(view * size_t(in.height) * size_t(in.width) + p) * 4 + size_t(ch)];
}

// One forward; progress "gsm" counts the GPU forward's stages from `first_stage` of `total_stages`.
nn::GsmOutputs run_forward(gpu::Context& ctx, const nn::GsmConfig& config, const nn::GsmWeights& w,
                           const nn::GsmInputs& in, bool cpu, const std::string& pass, GsmLiftStats& stats,
                           const GsmLiftOptions& o, size_t first_stage, size_t total_stages) {
  if (cpu) {
    nn::GsmOutputs out = nn::gsm_forward_reference(config, w, in, nullptr);
    if (o.progress) o.progress("gsm", first_stage + nn::GsmGpu::kStages, total_stages);
    return out;
  }
  nn::GsmGpu gsm(ctx, config, w);
  if (o.progress)
    gsm.set_progress([&](const nn::GsmGpu::Stage&, size_t done, size_t) { o.progress("gsm", first_stage + done, total_stages); });
  nn::GsmOutputs out = gsm.forward(in);
  for (const nn::GsmGpu::Stage& s : gsm.last_stages()) stats.stages_ms.emplace_back(pass + ": " + s.label, s.ms);
  return out;
}

}  // namespace

GsmModelPaths gsm_model_paths(const std::string& dir) {
  if (!fs::is_directory(dir))
    throw scene::InputError(dir, "", std::string("not a folder (a GSM model folder holds ") + kGsmConfigFile + " and " +
                                         kGsmWeightsFile + ", as tools/convert_checkpoint.py writes them)");
  GsmModelPaths p{(fs::path(dir) / kGsmConfigFile).string(), (fs::path(dir) / kGsmWeightsFile).string()};
  for (const std::string& f : {p.config, p.weights})
    if (!fs::is_regular_file(f)) throw scene::InputError(f, "", "missing (a GSM model folder needs it)");
  return p;
}

nn::GsmModelConfig load_gsm_lift_config(const GsmModelPaths& paths) { return nn::load_gsm_model_config(paths.config); }

GsmLiftModel load_gsm_lift_model(const GsmModelPaths& paths) {
  GsmLiftModel m;
  m.paths = paths;
  m.model = load_gsm_lift_config(paths);
  m.weights = nn::load_gsm_weights(paths.weights, m.model, true);
  return m;
}

uint64_t gsm_max_view_pixels(uint64_t max_binding_bytes) { return max_binding_bytes / (64 * 4); }

GsmLiftPlan gsm_lift_plan(size_t frames, uint32_t frame_width, uint32_t frame_height, const std::string& source,
                          const nn::GsmConfig& config, const GsmLiftOptions& o) {
  if (o.key_every == 0) throw std::invalid_argument("key_every must be at least 1");
  if (frames == 0) throw scene::InputError(source, "", "no frames to lift");
  GsmLiftPlan plan;
  for (size_t f = 0; f < frames; f += o.key_every) plan.key_frames.push_back(f);
  plan.width = o.width ? o.width : frame_width;
  plan.height = o.height ? o.height : frame_height;
  const uint32_t sky = uint32_t(std::max(1, config.sky.patch_size)), depth = uint32_t(std::max(1, config.pixel.depth_patch_size));
  const uint32_t P = std::max(sky, depth);
  const bool whole = plan.width % sky == 0 && plan.height % sky == 0 && plan.width % depth == 0 && plan.height % depth == 0;
  if (plan.width < P || plan.height < P || !whole) {
    const uint32_t w = std::max(P, plan.width / P * P), h = std::max(P, plan.height / P * P);
    throw scene::InputError(source, "",
                            "the GSM's input size " + size_text(plan.width, plan.height) + " is not made of whole " +
                                std::to_string(P) + "-pixel patches (its sky and depth patches): give the model's input "
                                "size (--gsm-size), e.g. " + size_text(w, h) + " (the frames are resized to it)");
  }
  const uint64_t view_pixels = uint64_t(plan.width) * plan.height;
  if (view_pixels > o.max_view_pixels)
    throw scene::InputError(source, "",
                            "the GSM's input size " + size_text(plan.width, plan.height) + " is " + std::to_string(view_pixels) +
                                " pixels per key frame, more than its limit of " + std::to_string(o.max_view_pixels) +
                                " (one key frame's 64-channel feature maps must fit one storage binding of " +
                                std::to_string(o.max_view_pixels * 64 * 4 >> 20) + " MiB on this device): give a "
                                "smaller input size (--gsm-size; the official one is 832x480)");
  const uint64_t pixels = uint64_t(plan.key_frames.size()) * plan.width * plan.height;
  if (pixels > o.max_pixels)
    throw scene::InputError(source, "",
                            std::to_string(plan.key_frames.size()) + " key frames of " + size_text(plan.width, plan.height) +
                                " are " + std::to_string(pixels) + " pixels for the GSM, more than its limit of " +
                                std::to_string(o.max_pixels) + ": lift from fewer key frames (a larger --key-every) "
                                "or at a smaller input size (--gsm-size)");
  return plan;
}

GsmLiftResult gsm_lift_frames(gpu::Context& ctx, const world::VoxelGrid& static_world, const std::string& world_name,
                              const std::string& frames_dir, const render::FramesMeta& meta, const GsmLiftModel& model,
                              const GsmLiftOptions& o) {
  const nn::GsmConfig& config = model.model.config;
  GsmLiftOptions sized = o;  // on the GPU, this device's storage bindings bound the key frames' size
  if (!o.cpu_reference) sized.max_view_pixels = gsm_max_view_pixels(ctx.info().max_storage_buffer_range);
  const GsmLiftPlan plan = gsm_lift_plan(meta.poses.size(), meta.width, meta.height,
                                         (fs::path(frames_dir) / "frames_meta.json").string(), config, sized);
  if (o.scene && o.dynamic && !o.car_mesh) throw std::invalid_argument("gsm_lift_frames: a scene needs the cars' mesh");
  GsmLiftResult res;
  res.model = model.paths;
  GsmLiftStats& st = res.gsm;
  LiftFramesResult& lr = res.lift;
  lr.key_frames = plan.key_frames;
  const size_t K = plan.key_frames.size();
  const uint32_t W = plan.width, H = plan.height;
  const size_t px = size_t(W) * H;
  st.width = W;
  st.height = H;
  st.views = K;

  // The grid and its voxels: checked before the frames are read.
  auto t0 = Clock::now();
  std::vector<glm::dvec3> cameras;
  for (size_t f : plan.key_frames) cameras.emplace_back(meta.poses[f][3]);
  const GsmGridFrame grid = gsm_grid_frame(static_world, cameras[0], world_name);
  st.grid_anchor = grid.anchor;
  st.grid_offset = grid.offset;
  const std::vector<nn::Ijk> voxels = gsm_crop_voxels(static_world, grid, cameras, o.radius);
  st.input_voxels = voxels.size();
  if (voxels.empty())
    throw scene::InputError(world_name, "", "no voxels within " + std::to_string(o.radius) + " m of the key cameras");
  if (voxels.size() > o.max_voxels)
    throw scene::InputError(world_name, "",
                            std::to_string(voxels.size()) + " voxels within " + std::to_string(o.radius) +
                                " m of the key cameras, more than the GSM's limit of " + std::to_string(o.max_voxels) +
                                ": lift from a smaller radius (--gsm-radius)");

  // The key frames at the model's size.
  std::vector<GsmFrame> frames;
  for (size_t k = 0; k < K; ++k) {
    frames.push_back(gsm_frame(read_frame_images(frames_dir, meta, plan.key_frames[k]), meta.width, meta.height, W, H));
    if (o.progress) o.progress("frames", k + 1, K);
  }
  const std::array<float, 6> intrinsics = gsm_intrinsics(meta.K, meta.pixels, W, H);

  // The static pass.
  nn::GsmInputs in = empty_inputs(1, int64_t(K), W, H, config);
  in.voxel_ijk = {voxels};
  for (size_t k = 0; k < K; ++k) {
    put_view(in, k, frames[k]);
    in.poses.push_back(gsm_pose(meta.poses[plan.key_frames[k]], grid));
    in.intrinsics.push_back(intrinsics);
    for (size_t p = 0; p < px; ++p) {
      mask_at(in, k, p, 0) = frames[k].sky[p] ? 0 : 1;
      mask_at(in, k, p, 1) = frames[k].instance[p] >= kDynamicInstanceMin ? 0 : 1;
      mask_at(in, k, p, 3) = 0;  // recomputed by the model
    }
  }
  // Key frames before the last pixel_frames: foreground = the grid foreground (ch0 = ch3).
  const size_t grid_views = K - std::min(o.pixel_frames, K);
  if (grid_views > 0) {
    nn::GsmInputs early;
    early.batch = 1;
    early.views = int64_t(grid_views);
    early.height = H;
    early.width = W;
    early.poses.assign(in.poses.begin(), in.poses.begin() + std::ptrdiff_t(grid_views));
    early.intrinsics.assign(in.intrinsics.begin(), in.intrinsics.begin() + std::ptrdiff_t(grid_views));
    early.voxel_ijk = in.voxel_ijk;
    const nn::GsmPixelRays rays = nn::cast_gsm_pixel_rays(early, 0);
    for (size_t k = 0; k < grid_views; ++k)
      for (size_t p = 0; p < px; ++p) mask_at(in, k, p, 0) = rays.grid_foreground[k * px + p];
  }
  nn::check_gsm_inputs(config, in, frames_dir);
  st.inputs_s = seconds_since(t0);

  t0 = Clock::now();
  const size_t total_stages = nn::GsmGpu::kStages * (o.scene && o.dynamic ? 2 : 1);
  if (o.progress) o.progress("gsm", 0, total_stages);
  {
    const nn::GsmOutputs out = run_forward(ctx, config, model.weights, in, o.cpu_reference, "static", st, o, 0, total_stages);
    if (out.elements.size() != 1) throw std::logic_error("gsm lift: the forward returned " + std::to_string(out.elements.size()) + " elements");
    const nn::VoxelGaussians& vox = out.elements[0].voxel;
    const nn::PixelGaussians& pix = out.elements[0].pixel;
    GsmConversionStats cs;
    append_gsm_gaussians(lr.cloud, gsm_gaussian_tensors(vox), grid.grid_to_world(), nullptr, &cs);
    append_gsm_gaussians(lr.cloud, gsm_gaussian_tensors(pix), grid.grid_to_world(), nullptr, &cs);
    st.voxel_gaussians = size_t(vox.count());
    st.pixel_gaussians = size_t(pix.count());
    st.floored_scales = cs.floored_scales;
    st.identity_rotations = cs.identity_rotations;
    const size_t per_front = size_t(config.voxel_heads.gaussians_per_voxel) * size_t(config.voxel_heads.occ_upsample) *
                             size_t(config.voxel_heads.occ_upsample) * size_t(config.voxel_heads.occ_upsample);
    st.front_voxels = size_t(std::count(vox.src_level.begin(), vox.src_level.end(), 0)) / std::max<size_t>(1, per_front);
    lr.pixel.gaussians = st.pixel_gaussians;
    lr.pixel.pixels = st.pixel_gaussians / size_t(std::max(1, config.pixel.gs_per_pixel));
    lr.sky = gsm_sky_image(out.sky_panorama);
  }
  st.forward_s = seconds_since(t0);

  // Splat-scene frames (as lift_frames): every scene state by time index, or the folder's frames.
  const bool by_time = splat_frames_are_times(meta);
  const size_t splat_frames = splat_frame_count(meta, o.scene);
  lr.splat_frames = splat_frames;

  // The dynamic pass.
  if (o.scene && o.dynamic) {
    t0 = Clock::now();
    struct DynamicView {
      size_t key = 0;
      int time = 0;
      std::vector<GsmObjectBox> boxes;
    };
    std::vector<DynamicView> dviews;
    for (size_t k = 0; k < K; ++k) {
      const bool any = std::any_of(frames[k].instance.begin(), frames[k].instance.end(),
                                   [](uint16_t i) { return i >= kDynamicInstanceMin; });
      const int t = time_index_of(meta, plan.key_frames[k]);
      std::vector<GsmObjectBox> boxes = object_boxes(*o.scene, t, grid);
      if (any && !boxes.empty()) dviews.push_back({k, t, std::move(boxes)});
    }
    st.dynamic_views = dviews.size();
    if (!dviews.empty()) {
      nn::GsmConfig dyn_config = config;
      dyn_config.pixel.midground_only = false;  // decode_all_pixel2gs
      nn::GsmInputs din = empty_inputs(int64_t(dviews.size()), 1, W, H, dyn_config);
      render::CarVoxelCache cache;
      for (size_t b = 0; b < dviews.size(); ++b) {
        const size_t k = dviews[b].key;
        put_view(din, b, frames[k]);
        din.poses.push_back(in.poses[k]);
        din.intrinsics.push_back(intrinsics);
        for (size_t p = 0; p < px; ++p) mask_at(din, b, p, 3) = 0;
        // The static voxels and the frame's cars (the cars' depth in the pixel branch's prior).
        std::vector<nn::Ijk> ijk = voxels;
        for (const render::CarCell& c : render::dynamic_car_cells(*o.scene, dviews[b].time, *o.car_mesh,
                                                                  static_world.origin(), static_world.voxel_size(), nullptr,
                                                                  &cache))
          ijk.push_back({c.ijk.x - grid.anchor.x, c.ijk.y - grid.anchor.y, c.ijk.z - grid.anchor.z});
        std::sort(ijk.begin(), ijk.end());
        ijk.erase(std::unique(ijk.begin(), ijk.end()), ijk.end());
        // Only the voxels the depth prior reads (the model's voxel branch runs on them; dropped).
        nn::GsmInputs one;
        one.batch = 1, one.views = 1, one.height = H, one.width = W;
        one.poses = {din.poses.back()};
        one.intrinsics = {intrinsics};
        one.voxel_ijk = {std::move(ijk)};
        din.voxel_ijk.push_back(gsm_depth_support(one, 0));
        st.dynamic_voxels += din.voxel_ijk.back().size();
      }
      nn::check_gsm_inputs(dyn_config, din, frames_dir);
      const nn::GsmOutputs dout = run_forward(ctx, dyn_config, model.weights, din, o.cpu_reference, "dynamic", st, o,
                                              nn::GsmGpu::kStages, total_stages);
      GsmObjectPicker picker;
      for (size_t b = 0; b < dviews.size(); ++b) {
        const nn::PixelGaussians& pg = dout.elements[b].pixel;
        const GsmFrame& fr = frames[dviews[b].key];
        std::vector<size_t> rows;
        for (size_t i = 0; i < size_t(pg.count()); ++i) {
          const size_t row = size_t(pg.src[4 * i + 1]), col = size_t(pg.src[4 * i + 2]);
          if (fr.instance[row * W + col] >= kDynamicInstanceMin) rows.push_back(i);
        }
        st.dynamic_candidates += rows.size();
        picker.add_frame(plan.key_frames[dviews[b].key], gsm_gaussian_tensors(pg), rows, dviews[b].boxes);
      }
      // Each object with its pose in every splat-scene frame where its track places it.
      for (const auto& [id, pick] : picker.picks()) {
        if (pick.rows.empty()) continue;
        splat::SplatObject obj;
        obj.id = id;
        obj.source = "object_" + std::to_string(id) + ".ply";
        GsmConversionStats cs;
        append_gsm_gaussians(obj.gaussians, pick.gaussians, pick.grid_to_object, &pick.rows, &cs);
        st.floored_scales += cs.floored_scales;
        st.identity_rotations += cs.identity_rotations;
        obj.poses.assign(splat_frames, glm::dmat4(1.0));
        obj.present.assign(splat_frames, 0);
        for (size_t f = 0; f < splat_frames; ++f) {
          const int t = by_time ? int(f) : time_index_of(meta, f);
          const std::map<uint16_t, glm::dmat4> poses = dynamic_object_poses(*o.scene, t);
          if (const auto it = poses.find(id); it != poses.end()) obj.poses[f] = it->second, obj.present[f] = 1;
        }
        lr.objects.push_back(std::move(obj));
      }
    }
    st.dynamic_s = seconds_since(t0);
    if (o.progress) o.progress("gsm", total_stages, total_stages);  // also when no key frame had dynamic pixels
  }

  evaluate_held_out_frames(ctx, frames_dir, meta, o.key_every, o.max_eval_frames, o.progress, lr);
  return res;
}

void write_gsm_lift_outputs(const std::string& dir, const render::FramesMeta& meta, const GsmLiftResult& r,
                            const GsmLiftOptions& o) {
  LiftFramesOptions lo;
  lo.key_every = o.key_every;
  lo.pixel_frames = o.pixel_frames;
  const nlohmann::ordered_json rep = lift_report(meta, r.lift, lo);
  const GsmLiftStats& s = r.gsm;
  nlohmann::ordered_json out;
  for (auto it = rep.begin(); it != rep.end(); ++it) {
    if (it.key() == "options") {
      out["method"] = "gsm";
      out["options"] = {{"key_every", o.key_every},
                        {"pixel_frames", o.pixel_frames},
                        {"input_size", {s.width, s.height}},
                        {"radius_m", o.radius},
                        {"dynamic", o.scene != nullptr && o.dynamic},
                        {"backend", o.cpu_reference ? "cpu" : "gpu"}};
    } else if (it.key() == "gaussians") {
      out["gaussians"] = {{"total", r.lift.cloud.size()}, {"voxel", s.voxel_gaussians}, {"pixel", s.pixel_gaussians}};
    } else if (it.key() == "samples" || it.key() == "sky_samples" || it.key() == "midground_pixels" ||
               it.key() == "dynamic_samples") {
      continue;  // the non-learned lift's counts
    } else {
      out[it.key()] = it.value();
    }
  }
  out["gsm"] = {{"config", r.model.config},
                {"weights", r.model.weights},
                {"views", s.views},
                {"input_voxels", s.input_voxels},
                {"front_voxels", s.front_voxels},
                {"midground_pixels", r.lift.pixel.pixels},
                {"grid_anchor_ijk", {s.grid_anchor.x, s.grid_anchor.y, s.grid_anchor.z}},
                {"grid_origin_world", {s.grid_offset.x, s.grid_offset.y, s.grid_offset.z}},
                {"dynamic_views", s.dynamic_views},
                {"dynamic_voxels", s.dynamic_voxels},
                {"dynamic_candidates", s.dynamic_candidates},
                {"floored_scales", s.floored_scales},
                {"identity_rotations", s.identity_rotations}};
  write_lift_outputs(dir, meta, r.lift, out);
}

}  // namespace icube::lift

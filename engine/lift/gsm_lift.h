// Stage 3 with the learned model: InfiniCube's feed-forward reconstruction
// model (the GSM, engine/nn/gsm) run on an appearance-frames folder and the
// voxel world, giving the same LiftFramesResult as the non-learned lift
// (lift_frames.h), so lift_output.h writes the same package and the held-out
// figures, `icube eval` and the viewer read it unchanged. As the official
// inference/scene_gaussian_generation.py:
//   key frames   every `key_every`-th frame from 0 (the official range(start 0, all frames, 6))
//   static pass  one batch element, the key frames as its views (gsm_lift_inputs.h: grid frame, voxels,
//                images, poses, intrinsics); masks: ch0 foreground by segmentation = not the folder's sky
//                mask for the last `pixel_frames` key frames (enable_pixel_branch_last_n_frame, 1) and, for
//                the earlier ones, the grid foreground (ch0 = ch3, so their pixel branch keeps nothing and
//                their sky is what the grid does not cover; here the model's own ray cast on its input
//                grid, nn/gsm/gsm_rays.h, as the engine's forward recomputes ch3: the official ch3 is the
//                guidance buffers' depth != 0, rendered from the whole world); ch1 not dynamic = instance
//                < 10000 (the official sets it to ones and bleeds car colours into the road behind them —
//                its comment says the mask is meant to hold the dynamic objects, ours does); ch2 ones.
//                The depth prior: the official swaps masked_voxel_depth for the guidance buffers' unmasked
//                voxel depth (update_pixel_branch_depth_source, provided_depth); the engine's model computes
//                the voxel depth itself, so every depth patch is kept (depth_patch_keep all 1). The
//                model's Gaussians: voxel branch, then pixel branch (DualBranchUNet's concatenation),
//                converted by gsm_gaussians.h into the world frame; the sky from its token (gsm_gaussians.h).
//   dynamic pass with a scene (_reconstruct_dynamic_objects): the pixel branch decodes every pixel
//                (decode_all_pixel2gs: ch0 ones, the mid-ground rule off), one batch element per key frame
//                that has dynamic pixels, its grid the static voxels plus that frame's cars (the official
//                depth prior, the guidance buffers' depth, sees the cars as CAD models); per object the key
//                frame with the most Gaussians inside its box (gsm_gaussians.h). The official runs the
//                pixel branch alone; the engine's model runs both branches, so each element gets only the
//                voxels its depth prior reads (gsm_depth_support.h: the same prior, a small voxel branch
//                whose Gaussians are dropped).
//   held-out     as lift_frames: the frames that are not key frames, rendered with the objects and sky.
// Sizes are checked before any work (gsm_lift_plan): the model's input size must be multiples of 16 (its
// sky and depth patches); views x pixels and the input voxels have limits that name what to reduce.
// Test: tests/lift/test_gsm_lift.cpp.
#pragma once

#include "lift/lift_frames.h"
#include "nn/gsm/gsm_params.h"
#include "nn/gsm/gsm_weights.h"

#include <functional>
#include <string>
#include <vector>

namespace icube::lift {

// tools/convert_checkpoint.py's file names in a model folder.
inline constexpr const char* kGsmConfigFile = "gsm_config.json";
inline constexpr const char* kGsmWeightsFile = "gsm.safetensors";

struct GsmModelPaths {
  std::string config;   // a config JSON or the preset "infinicube-gsm"
  std::string weights;  // .safetensors
};

// DIR/gsm_config.json and DIR/gsm.safetensors; scene::InputError naming a missing one.
GsmModelPaths gsm_model_paths(const std::string& dir);

struct GsmLiftModel {
  GsmModelPaths paths;
  nn::GsmModelConfig model;
  nn::GsmWeights weights;
};

// The configuration (load_gsm_model_config) and the weights checked against its state dict, every tensor
// finite (load_gsm_weights(..., true)); scene::InputError naming the file otherwise.
GsmLiftModel load_gsm_lift_model(const GsmModelPaths& paths);
// The configuration alone (the size checks before the weights are read).
nn::GsmModelConfig load_gsm_lift_config(const GsmModelPaths& paths);

// The most pixels per key frame a device whose storage bindings hold max_binding_bytes takes: one key
// frame's widest tensors (64 float channels at full resolution: the conv encoder's features, x-unet's
// first level) must fit one binding. 524,288 on lavapipe (128 MiB; the official 832 x 480 is 399,360),
// 16.7 M with NVIDIA's 4 GiB.
uint64_t gsm_max_view_pixels(uint64_t max_binding_bytes);

struct GsmLiftOptions {
  size_t key_every = 6;     // the official use_frame_interval
  size_t pixel_frames = 1;  // pixel branch on the last N key frames (0 = off)
  uint32_t width = 0, height = 0;  // the model's input size; 0 = the frames' size
  double radius = 80.0;     // input voxels within this many metres (x, y) of a key camera; <= 0: all
  uint64_t max_pixels = 24ull * 480 * 832;  // key frames x width x height
  // width x height: one key frame's widest tensors must fit one storage binding (gsm_max_view_pixels); the
  // default is lavapipe's 128 MiB; gsm_lift_frames on the GPU and the callers' checks before work (icube lift,
  // icube generate) use their device's
  uint64_t max_view_pixels = gsm_max_view_pixels(128ull << 20);
  uint64_t max_voxels = 3'000'000;          // input voxels
  bool cpu_reference = false;  // the plain CPU reference (nn/gsm/gsm_reference.h) instead of the GPU
  bool dynamic = true;         // the dynamic pass (needs `scene`)
  const scene::Scene* scene = nullptr;            // the scene the frames were rendered with (cars, tracks)
  const world::TriangleMesh* car_mesh = nullptr;  // its cars' mesh
  size_t max_eval_frames = 4;
  std::function<void(const char* stage, size_t done, size_t total)> progress;  // "frames", "gsm", "eval"
};

// What the lift will run on `frames` frames of frame_width x frame_height and the configuration;
// scene::InputError (on `source`, naming what to reduce or change) for a size the model does not take or
// past the limits. `icube generate` checks its camera path with it before any stage.
struct GsmLiftPlan {
  std::vector<size_t> key_frames;
  uint32_t width = 0, height = 0;  // the model's input size
};
GsmLiftPlan gsm_lift_plan(size_t frames, uint32_t frame_width, uint32_t frame_height, const std::string& source,
                          const nn::GsmConfig& config, const GsmLiftOptions& o);

struct GsmLiftStats {
  uint32_t width = 0, height = 0;
  size_t views = 0;
  size_t input_voxels = 0, front_voxels = 0;
  size_t voxel_gaussians = 0, pixel_gaussians = 0;
  // The dynamic pass: key frames run, their input voxels (the depth prior's support), dynamic-pixel Gaussians.
  size_t dynamic_views = 0, dynamic_voxels = 0, dynamic_candidates = 0;
  size_t floored_scales = 0, identity_rotations = 0;
  glm::ivec3 grid_anchor{0};
  glm::dvec3 grid_offset{0.0};
  double inputs_s = 0.0, forward_s = 0.0, dynamic_s = 0.0;
  std::vector<std::pair<std::string, double>> stages_ms;  // the GPU forwards' stages ("static: ...", "dynamic: ...")
};

struct GsmLiftResult {
  GsmModelPaths model;
  LiftFramesResult lift;  // cloud = voxel then pixel Gaussians; pixel.gaussians = the pixel branch's count
  GsmLiftStats gsm;
};

GsmLiftResult gsm_lift_frames(gpu::Context& ctx, const world::VoxelGrid& static_world, const std::string& world_name,
                              const std::string& frames_dir, const render::FramesMeta& meta, const GsmLiftModel& model,
                              const GsmLiftOptions& o);

// write_lift_outputs (the same files) with lift_report.json's "method": "gsm", the GSM's options and its
// counts ("gsm") in place of the non-learned options.
void write_gsm_lift_outputs(const std::string& dir, const render::FramesMeta& meta, const GsmLiftResult& r,
                            const GsmLiftOptions& o);

}  // namespace icube::lift

// The GSM's whole forward on the CPU; see gsm_reference.h.
#include "nn/gsm/gsm_reference.h"

#include "nn/gsm/gsm_json.h"
#include "nn/gsm/gsm_rays.h"
#include "scene/atomic_file.h"
#include "scene/input_error.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <string>

namespace icube::nn {

namespace {

void require_text(const nlohmann::json& h, const std::string& key, const std::string& want, const std::string& source) {
  const std::string got = gsm_json::text(h, key, source);
  if (got != want) throw scene::InputError(source, key, "\"" + got + "\" is not implemented (only \"" + want + "\")");
}

// [rows, ...] views of batch element b of a [B * N, ...] tensor.
CpuTensor element_views(const CpuTensor& x, int64_t b, int64_t views) {
  std::vector<int64_t> shape = x.shape;
  shape[0] = views;
  const int64_t per = x.per_item() * views;
  return CpuTensor(shape, std::vector<float>(x.data.begin() + b * per, x.data.begin() + (b + 1) * per));
}

TensorToWrite i32_of(std::string name, std::vector<int64_t> shape, const std::vector<int32_t>& v) {
  return i32_tensor(std::move(name), std::move(shape), v);
}

}  // namespace

GsmConfig gsm_config_from_json(const nlohmann::json& config, const std::string& source) {
  try {
    const nlohmann::json& h = gsm_json::at(config, "hparams", source);
    require_text(h, "model", "gsm", source);
    require_text(h, "backbone.target", "DualBranchUNet", source);
    if (gsm_json::boolean(h, "encoder.resize_projection_input", source))
      throw scene::InputError(source, "encoder.resize_projection_input", "true (resized encoder input) is not implemented");
    const std::vector<std::string> modules = gsm_json::at(h, "encoder.encoder_modules", source).get<std::vector<std::string>>();
    if (modules != std::vector<std::string>{"conv", "dav2"})
      throw scene::InputError(source, "encoder.encoder_modules", "only [\"conv\", \"dav2\"] is implemented");
    if (!gsm_json::boolean(h, "backbone.params.use_3d", source) || !gsm_json::boolean(h, "backbone.params.use_2d", source))
      throw scene::InputError(source, "backbone.params.use_3d", "only the dual-branch model (use_3d and use_2d) is implemented");
    require_text(h, "backbone.params.backbone_3d_params.img_feature_source", "conv", source);
    GsmConfig c;
    c.source = source;
    c.conv = conv_encoder_config_from_json(h);
    c.dav2 = dav2_config_from_json(config);
    c.sky = sky_config_from_json(h);
    c.voxel_unet = voxel_unet_config_from_json(h);
    c.voxel_heads = voxel_heads_config_from_json(h);
    c.pixel = pixel_branch_config_from_json(h);
    if (c.voxel_unet.image_channels != c.conv.out_dim)
      throw scene::InputError(source, "backbone.params.backbone_3d_params.lifter_params.img_in_dim",
                              std::to_string(c.voxel_unet.image_channels) + " differs from the conv encoder's output width " +
                                  std::to_string(c.conv.out_dim));
    return c;
  } catch (const nlohmann::json::exception& e) {
    throw scene::InputError(source, "", std::string("malformed GSM config: ") + e.what());
  } catch (const scene::InputError& e) {
    // The stages' readers name "the GSM config"; the message names the file.
    const std::string generic = "the GSM config: ", what = e.what();
    if (e.file() != "the GSM config" || what.rfind(generic, 0) != 0) throw;
    throw scene::InputError(source, "", what.substr(generic.size()));
  } catch (const std::invalid_argument& e) {  // the readers' unsupported options
    throw scene::InputError(source, "", e.what());
  }
}

GsmConfig read_gsm_config(const std::string& path) {
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(scene::read_file(path));
  } catch (const nlohmann::json::exception& e) {
    throw scene::InputError(path, "", std::string("not JSON: ") + e.what());
  }
  return gsm_config_from_json(j, path);
}

void check_gsm_inputs(const GsmConfig& c, const GsmInputs& in, const std::string& dir) {
  const int64_t P = c.sky.patch_size, D = c.pixel.depth_patch_size;
  if (in.height % P || in.width % P || in.height % D || in.width % D)
    throw scene::InputError(dir + "/images.npy", "", "H x W = " + std::to_string(in.height) + " x " + std::to_string(in.width) +
                                                         " must be multiples of the sky and depth patch sizes (" +
                                                         std::to_string(P) + ", " + std::to_string(D) + ")");
  for (size_t v = 0; v < in.intrinsics.size(); ++v)
    if (static_cast<int64_t>(in.intrinsics[v][4]) != in.width || static_cast<int64_t>(in.intrinsics[v][5]) != in.height)
      throw scene::InputError(dir + "/intrinsics.npy", "view " + std::to_string(v),
                              "width and height (entries 4, 5) differ from the images' " + std::to_string(in.width) + " x " +
                                  std::to_string(in.height));
}

GsmOutputs gsm_forward_reference(const GsmConfig& c, const GsmWeights& w, const GsmInputs& in, GsmTrace* trace) {
  const int64_t B = in.batch, N = in.views, H = in.height, W = in.width;
  GsmOutputs out;
  // 1-2. Masks and image features.
  const CpuTensor images = gsm_images_nchw(in);
  const CpuTensor effective = gsm_effective_mask(in);  // [B, N, H, W]
  trace_put(trace, "enc.effective_mask", effective);
  const CpuTensor conv = conv_encoder_forward(c.conv, w, images, trace);  // [V, C, H, W]
  if (trace) {
    CpuTensor t = conv;
    t.shape.insert(t.shape.begin(), B);
    t.shape[1] = N;
    trace_put(trace, "enc.conv.out", t);
  }
  const CpuTensor dav2 = dav2_features(c.dav2, w, images, trace, B);  // [V, C, h, w]
  // 3. The sky token.
  out.sky_tokens = sky_tokens(c.sky, w, in, images, trace);
  // 4. Pixel rays.
  std::vector<GsmPixelRays> rays;
  for (int64_t b = 0; b < B; ++b) rays.push_back(cast_gsm_pixel_rays(in, b));
  trace_gsm_pixel_rays(rays, trace);
  CpuTensor voxel_depth({B * N, 1, H, W});
  std::vector<uint8_t> grid_fg;
  for (int64_t b = 0; b < B; ++b) {
    std::copy(rays[static_cast<size_t>(b)].voxel_depth.begin(), rays[static_cast<size_t>(b)].voxel_depth.end(),
              voxel_depth.data.begin() + b * N * H * W);
    grid_fg.insert(grid_fg.end(), rays[static_cast<size_t>(b)].grid_foreground.begin(), rays[static_cast<size_t>(b)].grid_foreground.end());
  }
  // 5. The voxel branch, one batch element at a time.
  out.elements.resize(static_cast<size_t>(B));
  for (int64_t b = 0; b < B; ++b) {
    const SparseGrid grid = gsm_input_grid(in, b);
    const CpuTensor features = element_views(conv, b, N);
    CpuTensor eff = element_views(CpuTensor({B * N, H, W}, effective.data), b, N);
    const int bi = static_cast<int>(b);
    VoxelBranchFeatures vb =
        voxel_branch_features(c.voxel_unet, w, grid, features, rays[static_cast<size_t>(b)].first_voxel, eff, bi, trace);
    VoxelHeadsInputs hi;
    hi.grid = grid;
    hi.voxel_features = std::move(vb.features);
    hi.front = std::move(vb.front.front);
    hi.front_per_view = std::move(vb.front.front_per_view);
    hi.image_features = features;
    hi.effective_mask = std::move(eff);
    hi.poses.assign(in.poses.begin() + b * N, in.poses.begin() + (b + 1) * N);
    hi.intrinsics.assign(in.intrinsics.begin() + b * N, in.intrinsics.begin() + (b + 1) * N);
    out.elements[static_cast<size_t>(b)].voxel = voxel_heads_forward(c.voxel_heads, w, hi, bi, trace);
  }
  // 6. The pixel branch.
  std::vector<PixelGaussians> pixel = pixel_branch_forward(c.pixel, w, in, voxel_depth, grid_fg, dav2, trace);
  for (int64_t b = 0; b < B; ++b) out.elements[static_cast<size_t>(b)].pixel = std::move(pixel[static_cast<size_t>(b)]);
  // 7. The sky's colours.
  out.sky_image = sky_image(c.sky, w, in, out.sky_tokens);
  out.sky_panorama = sky_panorama(c.sky, w, out.sky_tokens, c.sky_panorama_rows);
  return out;
}

std::vector<TensorToWrite> gsm_output_tensors(const GsmOutputs& out) {
  std::vector<TensorToWrite> t;
  for (size_t b = 0; b < out.elements.size(); ++b) {
    const std::string p = "gs.b" + std::to_string(b) + ".";
    const VoxelGaussians& v = out.elements[b].voxel;
    const PixelGaussians& x = out.elements[b].pixel;
    for (const auto& [name, tensor] : {std::pair{"voxel.means", &v.means}, {"voxel.scales", &v.scales},
                                       {"voxel.rotations", &v.rotations}, {"voxel.opacities", &v.opacities},
                                       {"voxel.colors", &v.colors}, {"pixel.means", &x.means}, {"pixel.scales", &x.scales},
                                       {"pixel.rotations", &x.rotations}, {"pixel.opacities", &x.opacities},
                                       {"pixel.colors", &x.colors}})
      t.push_back(f32_tensor(p + name, tensor->shape, tensor->data));
    t.push_back(i32_of(p + "voxel.src_ijk", {v.count(), 3}, v.src_ijk));
    t.push_back(i32_of(p + "voxel.src_level", {v.count()}, v.src_level));
    t.push_back(i32_of(p + "voxel.src_sub", {v.count()}, v.src_sub));
    t.push_back(i32_of(p + "pixel.src", {x.count(), 4}, x.src));
  }
  t.push_back(f32_tensor("sky.tokens", out.sky_tokens.shape, out.sky_tokens.data));
  t.push_back(f32_tensor("sky.image", out.sky_image.shape, out.sky_image.data));
  t.push_back(f32_tensor("sky.panorama", out.sky_panorama.shape, out.sky_panorama.data));
  return t;
}

std::vector<TensorToWrite> gsm_trace_tensors(const GsmTrace& trace) {
  std::vector<TensorToWrite> t;
  for (const auto& [name, tensor] : trace.tensors) t.push_back(f32_tensor(name, tensor.shape, tensor.data));
  return t;
}

}  // namespace icube::nn

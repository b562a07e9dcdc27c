// The GSM's pixel branch CPU reference (engine/nn/gsm/pixel_branch_reference.h,
// xunet_reference.h) against the official gsm_small case
// (../shared/data/models/gsm_small): the x-unet fed pix.unet_in (every pix.unet.*
// block and pix.unet_out), then the whole branch fed its inputs (voxel depth,
// grid-foreground mask, DAV2 feature from the reference) through to the pixel
// Gaussians gs.b0.pixel.*, all within 1e-4 of their std, integers exact.
#include <doctest/doctest.h>

#include "gsm_case.h"
#include "nn/gsm/gsm_inputs.h"
#include "nn/gsm/pixel_branch_reference.h"
#include "nn/gsm/xunet_reference.h"
#include "scene/atomic_file.h"

#include <nlohmann/json.hpp>

#include <stdexcept>
#include <string>

using namespace icube;

namespace {

nlohmann::json case_hparams(const std::string& dir) {
  return nlohmann::json::parse(scene::read_file(dir + "config.json")).at("hparams");
}

nn::CpuTensor as_int_tensor(const std::vector<int32_t>& v, std::vector<int64_t> shape) {
  return nn::CpuTensor(std::move(shape), std::vector<float>(v.begin(), v.end()));
}

}  // namespace

TEST_CASE("gsm reference: the pixel branch's x-unet matches pix.unet.*") {
  // The released unet2d_params: per-stage values as lists, XUnet's defaults for the attention; options the
  // reference does not implement are refused.
  nlohmann::json released = nlohmann::json::parse(R"({"channels": 36, "init_dim": 32, "dim": 32, "out_dim": 24,
    "dim_mults": [1, 2, 4, 8], "num_blocks_per_stage": [2, 2, 2, 2], "num_self_attn_per_stage": [0, 0, 0, 0],
    "consolidate_upsample_fmaps": true})");
  const nn::XUnetConfig rc = nn::xunet_config_from_json(released);
  CHECK(rc.stages() == 4);
  CHECK(rc.channels == 36);
  CHECK(rc.out_dim == 24);
  CHECK(rc.attn_heads == std::vector<int>{8, 8, 8, 8});
  CHECK(rc.skip_scale == doctest::Approx(0.70710678));
  released["num_blocks_per_stage"] = 3;
  CHECK(nn::xunet_config_from_json(released).num_blocks_per_stage == std::vector<int>{3, 3, 3, 3});
  released["num_blocks_per_stage"] = nlohmann::json::array({2, 2});
  CHECK_THROWS(nn::xunet_config_from_json(released));
  released["num_blocks_per_stage"] = 2;
  released["num_self_attn_per_stage"] = nlohmann::json::array({0, 0, 0, 1});
  CHECK_THROWS_AS(nn::xunet_config_from_json(released), std::invalid_argument);

  const std::string dir = test::gsm_small_dir();
  if (dir.empty()) return;
  const nn::PixelBranchConfig c = nn::pixel_branch_config_from_json(case_hparams(dir));
  CHECK(c.unet.dim == 8);
  CHECK(c.unet.channels == 12);
  CHECK(c.unet.out_dim == 12);
  CHECK(c.unet.attn_heads.back() == 8);  // XUnet's defaults (the config leaves them out)
  CHECK(c.unet.attn_dim_head.back() == 32);
  const nn::GsmWeights w = nn::load_gsm_weights(dir + "weights.safetensors");
  const test::GsmTensors ref(dir + "intermediates.safetensors");
  nn::GsmTrace trace;
  const nn::CpuTensor out = nn::xunet_forward(c.unet, w, "backbone.backbone_2d.net.", ref.get("pix.unet_in"), &trace);
  // init_conv, 4 down stages x 3, mid x 4, 3 up stages x 3, consolidator.
  CHECK(trace.tensors.size() == 1 + 4 * 3 + 4 + 3 * 3 + 1);
  for (const auto& [name, t] : trace.tensors) {
    REQUIRE_MESSAGE(ref.has(name), "the reference has no " << name);
    test::check_gsm_tensor(ref, name, t);
  }
  test::check_gsm_tensor(ref, "pix.unet_out", out);
}

TEST_CASE("gsm reference: the pixel branch matches its intermediates and the pixel Gaussians") {
  const std::string dir = test::gsm_small_dir();
  if (dir.empty()) return;
  const nn::PixelBranchConfig c = nn::pixel_branch_config_from_json(case_hparams(dir));
  CHECK(c.masked_voxel_depth_prior);
  CHECK(c.dav2_feature_prior);
  CHECK(c.midground_only);
  const nn::GsmWeights w = nn::load_gsm_weights(dir + "weights.safetensors");
  const nn::GsmInputs in = nn::read_gsm_inputs(dir + "inputs");
  const test::GsmTensors ref(dir + "intermediates.safetensors"), outputs(dir + "outputs.safetensors");
  const int64_t V = in.batch * in.views;

  // The case's depth-patch draw is the one the model used.
  const nn::CpuTensor keep = ref.get("pix.depth_patch_keep");
  REQUIRE(keep.data.size() == in.depth_patch_keep.size());
  for (size_t i = 0; i < keep.data.size(); ++i) REQUIRE(keep.data[i] == static_cast<float>(in.depth_patch_keep[i]));

  // The stage's inputs, from the reference: voxel depth [V, 1, H, W], grid mask [V, H, W], DAV2 [B, N, C, h, w] -> [V, C, h, w].
  nn::CpuTensor voxel_depth = ref.get("pix.voxel_depth");
  voxel_depth.shape = {V, 1, in.height, in.width};
  const nn::CpuTensor grid = ref.get("pre.grid_fg_mask");
  const std::vector<uint8_t> grid_fg(grid.data.begin(), grid.data.end());
  nn::CpuTensor dav2 = ref.get("enc.dav2.out");
  dav2.shape = {V, dav2.dim(2), dav2.dim(3), dav2.dim(4)};

  nn::GsmTrace trace;
  const std::vector<nn::PixelGaussians> gs = nn::pixel_branch_forward(c, w, in, voxel_depth, grid_fg, dav2, &trace);
  for (const char* name : {"pix.masked_voxel_depth", "pix.unet_in", "pix.unet.consolidator", "pix.unet_out", "pix.gs_params",
                           "pix.gaussian_pixel_mask"}) {
    REQUIRE_MESSAGE(trace.tensors.count(name), name);
    test::check_gsm_tensor(ref, name, trace.tensors.at(name));
  }

  REQUIRE(gs.size() == 1);
  const nn::PixelGaussians& g = gs[0];
  test::check_gsm_tensor(outputs, "gs.b0.pixel.means", g.means);
  test::check_gsm_tensor(outputs, "gs.b0.pixel.scales", g.scales);
  test::check_gsm_tensor(outputs, "gs.b0.pixel.rotations", g.rotations);
  test::check_gsm_tensor(outputs, "gs.b0.pixel.opacities", g.opacities);
  test::check_gsm_tensor(outputs, "gs.b0.pixel.colors", g.colors);
  test::check_gsm_tensor(outputs, "gs.b0.pixel.src", as_int_tensor(g.src, {g.count(), 4}));

  // A DAV2 feature for the wrong number of views is refused.
  nn::CpuTensor two_views = dav2;
  two_views.shape[0] = 2 * V;
  two_views.data.resize(two_views.data.size() * 2);
  CHECK_THROWS_AS(nn::pixel_branch_forward(c, w, in, voxel_depth, grid_fg, two_views, nullptr), std::invalid_argument);
}

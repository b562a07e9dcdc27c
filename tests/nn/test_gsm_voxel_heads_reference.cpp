// The GSM voxel branch's Gaussian heads (engine/nn/gsm/voxel_heads_reference.h)
// against the official gsm_small case (../shared/data/models/gsm_small): fed the
// reference U-Net output, front masks, conv features and effective mask, every
// traced intermediate (vox.occ.b0.*, vox.nonocc.b0.*) and the voxel Gaussians
// (gs.b0.voxel.*) within 1e-4 of their std, integers exact; and the settings the
// reference refuses.
#include <doctest/doctest.h>

#include "gsm_case.h"
#include "nn/gsm/gsm_inputs.h"
#include "nn/gsm/voxel_heads_reference.h"
#include "scene/atomic_file.h"
#include "scene/input_error.h"

#include <nlohmann/json.hpp>

#include <string>
#include <vector>

using namespace icube;

namespace {

std::vector<uint8_t> as_bytes(const nn::CpuTensor& t) {
  std::vector<uint8_t> out;
  for (float v : t.data) out.push_back(v != 0.0f ? 1 : 0);
  return out;
}

nn::CpuTensor int_tensor(const std::vector<int32_t>& v, std::vector<int64_t> shape) {
  std::vector<float> f(v.begin(), v.end());
  return nn::CpuTensor(std::move(shape), std::move(f));
}

}  // namespace

TEST_CASE("gsm reference: the voxel heads and Gaussian decoding match vox.occ/nonocc and gs.b0.voxel.*") {
  const std::string dir = test::gsm_small_dir();
  if (dir.empty()) return;
  const nlohmann::json hparams = nlohmann::json::parse(scene::read_file(dir + "config.json")).at("hparams");
  const nn::VoxelHeadsConfig c = nn::voxel_heads_config_from_json(hparams);
  CHECK(c.width_3d == 16);
  CHECK(c.width_2d == 16);
  CHECK(c.gaussians_per_voxel == 4);
  CHECK(c.occ_upsample == 2);
  CHECK(c.max_scaling == 1.0);

  const nn::GsmWeights w = nn::load_gsm_weights(dir + "weights.safetensors");
  const nn::GsmInputs gi = nn::read_gsm_inputs(dir + "inputs");
  const test::GsmTensors ref(dir + "intermediates.safetensors"), out(dir + "outputs.safetensors");

  nn::VoxelHeadsInputs in;
  in.grid.ijk = gi.voxel_ijk.at(0);
  in.grid.voxel_size = {0.2, 0.2, 0.2};  // the case's input grid (README "Files")
  in.grid.origin = {0.1, 0.1, 0.1};
  in.voxel_features = ref.get("vox.out.b0");
  in.front = as_bytes(ref.get("vox.occ_front_mask.b0"));
  in.front_per_view = as_bytes(ref.get("vox.occ_front_per_camera.b0"));
  in.image_features = ref.get("enc.conv.out");  // [B=1, N, C, h, w] -> batch element 0
  in.image_features.shape.erase(in.image_features.shape.begin());
  in.effective_mask = ref.get("enc.effective_mask");
  in.effective_mask.shape.erase(in.effective_mask.shape.begin());
  in.poses.assign(gi.poses.begin(), gi.poses.begin() + gi.views);
  in.intrinsics.assign(gi.intrinsics.begin(), gi.intrinsics.begin() + gi.views);

  nn::GsmTrace trace;
  const nn::VoxelGaussians g = nn::voxel_heads_forward(c, w, in, 0, &trace);
  for (const char* name : {"vox.occ.b0.ijk", "vox.occ.b0.head_in", "vox.occ.b0.head_out", "vox.nonocc.b0.ijk",
                           "vox.nonocc.b0.head_in", "vox.nonocc.b0.head_out"}) {
    REQUIRE_MESSAGE(trace.tensors.count(name), name);
    test::check_gsm_tensor(ref, name, trace.tensors.at(name));
  }
  const int64_t n = g.count();
  test::check_gsm_tensor(out, "gs.b0.voxel.means", g.means);
  test::check_gsm_tensor(out, "gs.b0.voxel.scales", g.scales);
  test::check_gsm_tensor(out, "gs.b0.voxel.rotations", g.rotations);
  test::check_gsm_tensor(out, "gs.b0.voxel.opacities", g.opacities);
  test::check_gsm_tensor(out, "gs.b0.voxel.colors", g.colors);
  test::check_gsm_tensor(out, "gs.b0.voxel.src_ijk", int_tensor(g.src_ijk, {n, 3}));
  test::check_gsm_tensor(out, "gs.b0.voxel.src_level", int_tensor(g.src_level, {n}));
  test::check_gsm_tensor(out, "gs.b0.voxel.src_sub", int_tensor(g.src_sub, {n}));

  // Settings outside the implemented voxel branch are refused, naming the key.
  nlohmann::json other = hparams;
  other["backbone"]["params"]["backbone_3d_params"]["gs_enhanced"] = "three";
  CHECK_THROWS_WITH_AS(nn::voxel_heads_config_from_json(other), doctest::Contains("gs_enhanced"), scene::InputError);
  other = hparams;
  other["backbone"]["params"]["backbone_3d_params"]["gs_free_space"] = "soft";
  CHECK_THROWS_WITH_AS(nn::voxel_heads_config_from_json(other), doctest::Contains("gs_free_space"), scene::InputError);
  // Inputs that disagree with the configuration are internal errors.
  nn::VoxelHeadsInputs bad = in;
  bad.front.pop_back();
  CHECK_THROWS_AS(nn::voxel_heads_forward(c, w, bad, 0, nullptr), std::invalid_argument);
}

// The GSM's pixel rays (engine/nn/gsm/gsm_rays.h) and the voxel branch's
// lifter and sparse U-Net (engine/nn/gsm/voxel_unet_reference.h): the ray walk's
// semantics on hand-made grids, and every traced intermediate against the
// official gsm_small case (../shared/data/models/gsm_small): integers equal,
// features within 1e-4 of their std.
#include <doctest/doctest.h>

#include "gsm_case.h"
#include "nn/gsm/gsm_inputs.h"
#include "nn/gsm/gsm_rays.h"
#include "nn/gsm/voxel_unet_reference.h"
#include "scene/atomic_file.h"
#include "scene/input_error.h"

#include <nlohmann/json.hpp>

#include <cmath>
#include <string>
#include <vector>

using namespace icube;
using nn::Ijk;

namespace {

nlohmann::json case_hparams(const std::string& dir) {
  return nlohmann::json::parse(scene::read_file(dir + "config.json")).at("hparams");
}

nn::SparseGrid unit_grid(std::vector<Ijk> ijk) {
  nn::SparseGrid g;
  g.ijk = std::move(ijk);
  g.voxel_size = {1.0, 1.0, 1.0};
  g.origin = {0.5, 0.5, 0.5};  // voxel ijk spans [ijk, ijk + 1) in world units
  return g;
}

const nn::CpuTensor& traced(const nn::GsmTrace& t, const std::string& name) {
  REQUIRE_MESSAGE(t.tensors.count(name), "not traced: " << name);
  return t.tensors.at(name);
}

}  // namespace

TEST_CASE("gsm reference: the voxel ray walk's first voxel and segments follow fVDB's semantics") {
  // Voxels x = 0, 1, (gap) 3 on the row y = z = 0, plus a lone voxel at (5, 3, 0) widening the box.
  const nn::VoxelRayGrid grid(unit_grid({{0, 0, 0}, {1, 0, 0}, {3, 0, 0}, {5, 3, 0}}));
  // Along +x from outside the box: first voxel row 0, runs [1, 3] and [4, 5].
  nn::VoxelRayWalk w = grid.march({-1.0, 0.5, 0.5}, {1.0, 0.0, 0.0});
  CHECK(w.first_voxel == 0);
  REQUIRE(w.segments.size() == 2);
  CHECK(w.segments[0][0] == doctest::Approx(1.0));
  CHECK(w.segments[0][1] == doctest::Approx(3.0));
  CHECK(w.segments[1][0] == doctest::Approx(4.0));
  CHECK(w.segments[1][1] == doctest::Approx(5.0));
  CHECK(w.first_segment_start(2.5) == -1.0);
  CHECK(w.first_segment_start(1.5) == doctest::Approx(1.0));
  // Starting inside voxel 1 (t >= 0 only): voxel 1 is the first hit, its run starts at 0.
  w = grid.march({1.5, 0.5, 0.5}, {1.0, 0.0, 0.0});
  CHECK(w.first_voxel == 1);
  CHECK(w.first_segment_start(0.1) == doctest::Approx(0.0));
  // Backwards from inside voxel 3: voxel 3 first, then the run 1, 0.
  w = grid.march({3.5, 0.5, 0.5}, {-1.0, 0.0, 0.0});
  CHECK(w.first_voxel == 2);
  REQUIRE(w.segments.size() == 2);
  CHECK(w.segments[1][0] == doctest::Approx(1.5));
  CHECK(w.segments[1][1] == doctest::Approx(3.5));
  // Cutting the corner of voxel 0 for 0.002 sqrt(2) before leaving the box: a hit, but a short run.
  const double s = std::sqrt(0.5);
  w = grid.march({-0.5, 0.502, 0.5}, {s, -s, 0.0});
  CHECK(w.first_voxel == 0);
  REQUIRE(w.segments.size() == 1);
  CHECK(w.segments[0][1] - w.segments[0][0] == doctest::Approx(0.002 * std::sqrt(2.0)));
  CHECK(w.first_segment_start(0.01) == -1.0);
  // Pointing away, or missing the box: nothing.
  CHECK(grid.march({-1.0, 0.5, 0.5}, {-1.0, 0.0, 0.0}).first_voxel == -1);
  CHECK(grid.march({-1.0, 0.5, 2.5}, {1.0, 0.0, 0.0}).segments.empty());
}

TEST_CASE("gsm reference: pixel rays give the official first voxels, grid mask and voxel depth") {
  const std::string dir = test::gsm_small_dir();
  if (dir.empty()) return;
  const nn::GsmInputs in = nn::read_gsm_inputs(dir + "inputs");
  const test::GsmTensors ref(dir + "intermediates.safetensors");
  std::vector<nn::GsmPixelRays> all;
  for (int64_t b = 0; b < in.batch; ++b) all.push_back(nn::cast_gsm_pixel_rays(in, b));
  nn::GsmTrace trace;
  nn::trace_gsm_pixel_rays(all, &trace);
  for (int64_t b = 0; b < in.batch; ++b) {
    const std::string name = "vox.lifter.pixel_first_voxel.b" + std::to_string(b);
    test::check_gsm_tensor(ref, name, traced(trace, name));
  }
  test::check_gsm_tensor(ref, "pre.grid_fg_mask", traced(trace, "pre.grid_fg_mask"));
  test::check_gsm_tensor(ref, "pix.voxel_depth", traced(trace, "pix.voxel_depth"));
  // The case is not degenerate: most of the view sees the grid, and some rays miss it.
  int64_t hits = 0;
  for (int32_t r : all[0].first_voxel) hits += r >= 0;
  CHECK(hits > 1000);
  CHECK(hits < static_cast<int64_t>(all[0].first_voxel.size()));
}

TEST_CASE("gsm reference: the voxel branch's lifter and sparse UNet match vox.*") {
  const std::string dir = test::gsm_small_dir();
  if (dir.empty()) return;
  const nn::GsmWeights w = nn::load_gsm_weights(dir + "weights.safetensors");
  const nn::GsmInputs in = nn::read_gsm_inputs(dir + "inputs");
  const test::GsmTensors ref(dir + "intermediates.safetensors");
  const nn::VoxelUnetConfig c = nn::voxel_unet_config_from_json(case_hparams(dir));
  CHECK(c.widths() == std::vector<int>{16, 16, 32, 64});
  REQUIRE(in.batch == 1);

  // Inputs of the stage from the reference: the conv features [1, 1, C, H, W] -> [N, C, H, W], the first voxels.
  nn::CpuTensor features = ref.get("enc.conv.out");
  features.shape.erase(features.shape.begin());
  const nn::CpuTensor first_ref = ref.get("vox.lifter.pixel_first_voxel.b0");
  std::vector<int32_t> first(first_ref.data.size());
  for (size_t i = 0; i < first.size(); ++i) first[i] = static_cast<int32_t>(first_ref.data[i]);
  nn::CpuTensor effective = nn::gsm_effective_mask(in);
  effective.shape.erase(effective.shape.begin());
  const nn::SparseGrid grid = nn::gsm_input_grid(in, 0);

  nn::GsmTrace trace;
  const nn::VoxelBranchFeatures out = nn::voxel_branch_features(c, w, grid, features, first, effective, 0, &trace);
  test::check_gsm_tensor(ref, "vox.lifter.in", traced(trace, "vox.lifter.in"));
  test::check_gsm_tensor(ref, "vox.lifter", traced(trace, "vox.lifter"));
  test::check_gsm_tensor(ref, "vox.occ_front_mask.b0", traced(trace, "vox.occ_front_mask.b0"));
  test::check_gsm_tensor(ref, "vox.occ_front_per_camera.b0", traced(trace, "vox.occ_front_per_camera.b0"));
  int64_t front = 0;
  for (uint8_t f : out.front.front) front += f;
  CHECK(front > 0);

  // The U-Net alone, from the reference lifter output.
  nn::GsmTrace unet;
  const nn::CpuTensor voxels = nn::voxel_unet_forward(c, w, grid, ref.get("vox.lifter"), 0, &unet);
  const std::vector<std::string> names = {"vox.encoders.Enc0.0",
                                          "vox.encoders.Enc1.0",
                                          "vox.encoders.Enc2.0",
                                          "vox.pre_kl_bottleneck.pre_kl_bottleneck_0.0",
                                          "vox.post_kl_bottleneck.post_kl_bottleneck_0.0",
                                          "vox.post_kl_bottleneck.post_kl_bottleneck_1.0",
                                          "vox.decoders.Dec-2.0",
                                          "vox.decoders.Dec-3.0",
                                          "vox.out.b0"};
  test::check_gsm_tensor(ref, "vox.pre_conv", traced(unet, "vox.pre_conv"));
  for (const std::string& name : names) {
    test::check_gsm_tensor(ref, name + ".ijk", traced(unet, name + ".ijk"));
    test::check_gsm_tensor(ref, name, traced(unet, name));
  }
  test::check_gsm_tensor(ref, "vox.out.b0", voxels);
  // The whole branch (own lifter) agrees with the U-Net run from the reference lifter output.
  test::check_gsm_tensor(ref, "vox.out.b0", out.features);
}

TEST_CASE("gsm reference: the voxel U-Net configuration refuses what it does not implement") {
  nlohmann::json h = nlohmann::json::parse(R"({"backbone": {"params": {"backbone_3d_target": "Pure3DUnet",
    "backbone_3d_params": {"lifter_params": {"img_in_dim": 64, "voxel_out_dim": 64}, "in_channels": 64,
    "num_blocks": 3, "f_maps": 64}}}})");
  const nn::VoxelUnetConfig released = nn::voxel_unet_config_from_json(h);
  CHECK(released.widths() == std::vector<int>{64, 64, 128, 256});
  CHECK(released.num_groups == 8);
  nlohmann::json& p = h["backbone"]["params"]["backbone_3d_params"];
  p["use_attention"] = true;
  CHECK_THROWS_AS(nn::voxel_unet_config_from_json(h), scene::InputError);
  p.erase("use_attention");
  p["neck_dense_type"] = "FIT";
  CHECK_THROWS_AS(nn::voxel_unet_config_from_json(h), scene::InputError);
  p.erase("neck_dense_type");
  p["lifter_params"]["voxel_out_dim"] = 32;
  CHECK_THROWS_AS(nn::voxel_unet_config_from_json(h), scene::InputError);
}

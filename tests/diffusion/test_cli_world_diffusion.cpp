// `icube world build --generator diffusion` end to end with tiny random-weight
// models of the official structures (presets infinicube-diffusion-tiny and
// infinicube-vae-tiny): a one-chunk scene (the demo town with its
// ego parked) and one DDIM step write a valid world, the latent kept, the
// summary printed (a step of this UNet at 64^3 is ~20 s on lavapipe: guidance
// and outpainting are covered by the sampler's own tests); a scale_factor from the
// weights' metadata is used; missing or mismatched models are one-line errors
// before any work, with no output. `icube nn random-weights` makes the UNet.
#include <doctest/doctest.h>

#include "cli_test_util.h"
#include "nn/random_weights.h"
#include "nn/safetensors.h"
#include "nn/unet_config.h"
#include "nn/unet_reference.h"
#include "nn/vae_config.h"
#include "scene/atomic_file.h"
#include "scene/scene_json.h"
#include "world/demo_scene.h"
#include "world/npy.h"
#include "world/world_file.h"

#include <filesystem>
#include <string>

using namespace icube;

namespace {

// Random weights; the VAE's structure heads biased towards "empty" (logit1 + 0.25), so the finer levels
// keep a few percent of the voxels instead of half (a street's occupancy, and a short test).
void write_weights(const std::vector<nn::ParamSpec>& specs, uint32_t seed, const std::string& path,
                   const std::map<std::string, std::string>& metadata = {}) {
  std::vector<nn::TensorToWrite> t;
  for (auto [name, w] : nn::random_weights(specs, seed)) {
    if (name.find("struct_convs") != std::string::npos && name.ends_with("OutConv.bias")) w.data = {0.0f, 0.25f};
    t.push_back(nn::f32_tensor(name, w.shape, w.data));
  }
  nn::write_safetensors(path, t, metadata);
}

}  // namespace

TEST_CASE("cli: icube world build --generator diffusion runs a tiny random model end to end" * doctest::test_suite("slow-gpu")) {
  test::TempDir tmp("cli-diffusion");
  const std::string dir = tmp.path.string();
  scene::Scene demo = world::make_demo_scene();
  for (scene::EgoPose& e : demo.ego) e.ego_to_world = demo.ego.front().ego_to_world;  // parked: one chunk
  scene::write_scene_json(demo, dir + "/demo.json");
  const nn::UNetConfig unet = nn::load_unet_config("infinicube-diffusion-tiny");
  const nn::VaeConfig vae = nn::load_vae_config("infinicube-vae-tiny");
  // The UNet from the CLI's random-weights (scale_factor in its metadata), the VAE biased as above.
  const test::CliRun made = test::run_icube("nn random-weights --model infinicube-diffusion-tiny --seed 3 --scale-factor 0.5 -o '" +
                                                dir + "/unet.safetensors'",
                                            tmp.path);
  REQUIRE_MESSAGE(made.code == 0, made.output);
  CHECK(made.output.find("random-weights: 232 tensors") != std::string::npos);
  CHECK(nn::SafetensorsFile(dir + "/unet.safetensors").find(nn::UNetReference(unet).parameters().front().name));
  write_weights(nn::vae_param_specs(vae, nn::VaePart::All), 4, dir + "/vae.safetensors");
  const std::string models = " --generator diffusion --model infinicube-diffusion-tiny --weights '" + dir +
                             "/unet.safetensors' --vae '" + dir + "/vae.safetensors' --vae-model infinicube-vae-tiny ";
  // One chunk: blocks mode would cover the town; trajectory mode on the demo's drive with a single key.
  const std::string out = dir + "/world.icw";
  test::CliRun r = test::run_icube("world build '" + dir + "/demo.json' -o '" + out + "'" + models +
                                       "--steps 1 --cfg 1 --no-vehicles --keep-latents '" + dir + "/latents'",
                                   tmp.path);
  INFO(r.output);
  REQUIRE(r.code == 0);
  CHECK(r.output.find("(diffusion generator)") != std::string::npos);
  CHECK(r.output.find("scale_factor 0.5 (" + dir + "/unet.safetensors metadata), precision fp32") != std::string::npos);
  CHECK(r.output.find("diffusion: conditions") != std::string::npos);
  const world::VoxelGrid w = world::load_world(out);
  CHECK(w.voxel_count() > 0);
  CHECK(std::filesystem::exists(dir + "/latents/chunk_0000.npy"));
  const world::NpyArray lat = world::read_npy(dir + "/latents/chunk_0000.npy");
  CHECK(lat.shape == std::vector<uint64_t>{1, 8, 64, 64, 64});

  // Bad inputs: before any work, one line, no output.
  const std::string bad = dir + "/bad.icw";
  r = test::run_icube("world build '" + dir + "/demo.json' -o '" + bad +
                          "' --generator diffusion --model infinicube-diffusion-tiny --weights '" + dir + "/unet.safetensors'",
                      tmp.path);
  CHECK(r.code != 0);
  CHECK(r.output.find("--generator diffusion needs --model, --weights (the UNet) and --vae") != std::string::npos);
  r = test::run_icube("world build '" + dir + "/demo.json' -o '" + bad +
                          "' --generator diffusion --model infinicube-diffusion-tiny --weights '" + dir + "/vae.safetensors' --vae '" +
                          dir + "/vae.safetensors' --vae-model infinicube-vae-tiny",
                      tmp.path);
  CHECK(r.code != 0);
  CHECK(r.output.find("vae.safetensors: tensor") != std::string::npos);  // UNet tensors missing: named
  // DPM-Solver++ is deterministic: an eta for it is refused before any work.
  r = test::run_icube("world build '" + dir + "/demo.json' -o '" + bad + "'" + models + "--sampler dpm++2m --eta 1", tmp.path);
  CHECK(r.code != 0);
  CHECK(r.output.find("sampler dpm++2m is deterministic") != std::string::npos);
  CHECK(!std::filesystem::exists(bad));
}

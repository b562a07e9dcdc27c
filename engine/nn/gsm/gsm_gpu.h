// The whole GSM on the GPU: the stages of gsm_reference.h in the same order,
// each through the network layer — the conv encoder and Depth-Anything-V2
// (one command list), the voxel branch per batch element, the pixel branch,
// the sky colours (the modulator MLP for every input pixel and the 256 x 512
// panorama: kernels/nn/gsm_sky_colors.h), the pixel rays on the engine's voxel ray caster (first hits,
// grid mask, voxel depth: gsm_rays_gpu.h; the rays it marks near a tie, ~1-2 %, re-marched in double on
// the host, so every pixel is the double reference's), the sky token's patch embedding and transformer
// (sky_token_gpu.h) — with what stays on the host named here:
//   the sky token's inputs  the used-patch mask, the patch rays' embedding and the gather of the used
//                     patches behind the query (sky_token_inputs), and from the token the modulator's
//                     adaLN vectors
// and the structure of the voxel branch (grids, row tables: integer bookkeeping, voxel_branch_gpu.h).
// Outputs, and with a trace every intermediate, come back under the reference's names and layouts, so
// the GPU forward is checked against gsm_small and the CPU reference alike. Test:
// tests/nn/test_gsm_forward_gpu.cpp.
#pragma once

#include "nn/gsm/dav2_gpu.h"
#include "nn/gsm/gsm_gpu_weights.h"
#include "nn/gsm/gsm_reference.h"
#include "kernels/nn/gsm_sky_colors.h"
#include "nn/parameter_store.h"

#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace icube::gpu {
class Context;
}

namespace icube::nn {

class GsmGpu {
 public:
  struct Stage {
    std::string label;
    double ms = 0.0;
    bool on_device = true;
  };

  // Checks that every stage of `c` runs on the GPU (scene::InputError naming the key otherwise) and uploads
  // the weights.
  GsmGpu(gpu::Context& ctx, const GsmConfig& c, const GsmWeights& w);
  ~GsmGpu();
  GsmGpu(const GsmGpu&) = delete;
  GsmGpu& operator=(const GsmGpu&) = delete;

  GsmOutputs forward(const GsmInputs& in, GsmTrace* trace = nullptr);

  const std::vector<Stage>& last_stages() const { return stages_; }
  // Called after each of the forward's kStages stages (long forwards show progress).
  static constexpr size_t kStages = 6;
  void set_progress(std::function<void(const Stage& finished, size_t done, size_t total)> f) { progress_ = std::move(f); }
  uint64_t weight_bytes() const { return store_->device_bytes(); }
  uint64_t last_activation_bytes() const { return activation_bytes_; }

 private:
  gpu::Context& ctx_;
  GsmConfig config_;
  const GsmWeights& weights_;  // the CPU-side stages' (the sky token, the sky's adaLN vectors)
  std::unique_ptr<ParameterStore> store_;
  std::unique_ptr<gpu::Buffer> sky_mlp_;  // the sky modulator's pos_emb and output layers (kernels/nn/gsm_sky_colors.h)
  std::unique_ptr<kernels::nn::GsmSkyColors> sky_colors_;
  Dav2PositionEmbeddings positions_;
  std::vector<Stage> stages_;
  std::function<void(const Stage&, size_t, size_t)> progress_;
  uint64_t activation_bytes_ = 0;
  void finish_stage(std::string label, double ms, bool on_device);
};

}  // namespace icube::nn

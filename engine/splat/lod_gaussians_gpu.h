// A large static Gaussian set resident on the GPU chunk by chunk at both
// levels of gaussian_lod.h (fine and coarse), and per view the set a frame
// draws assembled on the GPU: the picked chunks' rows copied into one frame
// set (vkCmdCopyBuffer, adjacent ranges merged; only when the picks change),
// then a small host-placed part behind them (the dynamic objects placed at the
// frame; uploaded only when it or the static count changes). The frame set is
// an ordinary GpuGaussians for SplatRendererGpu, at the static set's origin
// (gaussian_origin), so the parts join without re-packing.
// Same Gaussians in the same order as select_gaussians + compose_frame (static
// chunks in chunk order, then the extra part), so the images equal the
// host path's; the host path copies and uploads every Gaussian every frame
// (bench/bench_lod.cpp: select + upload ~30 ms per frame at 350 k Gaussians on
// lavapipe), this one a few memcpy-speed GPU copies when the chunk set changes.
// The CPU copies of the clouds are not kept: only the chunk bounds.
// Tests: tests/splat/test_gaussian_lod.cpp.
#pragma once

#include "gpu/buffer.h"
#include "gpu/context.h"
#include "splat/gaussian_lod.h"
#include "splat/rasterizer_gpu.h"

#include <cstdint>
#include <vector>

namespace icube::splat {

struct LodAssembleStats {
  bool static_copied = false;  // the picks changed (or the frame set grew): static rows copied
  bool extra_uploaded = false;
  uint32_t copy_regions = 0;   // merged ranges copied
  double ms = 0.0;             // host wall clock of the assembly (copies + upload, waited)
};

class LodGaussiansGpu {
 public:
  // `sh_degree`: the frame set's SH degree, at least the chunks' (the extra parts' highest).
  LodGaussiansGpu(gpu::Context& ctx, const ChunkedGaussians& chunks, uint32_t sh_degree);

  const std::vector<GaussianChunk>& chunks() const { return chunks_; }
  const glm::dvec3& origin() const { return frame_.origin; }
  uint32_t sh_degree() const { return frame_.sh_degree; }
  // Resident bytes of both levels (the frame set not included).
  uint64_t resident_bytes() const;

  // The part drawn behind the static chunks (placed objects), packed now, uploaded at the next
  // assemble. Its SH degree must not pass sh_degree().
  void set_extra(const GaussianCloud& extra);
  // The frame set of `picks` (pick_chunks) + the extra part. Submits and waits for its copies;
  // the caller makes sure no earlier frame still reads the frame set.
  const GpuGaussians& assemble(const std::vector<ChunkPick>& picks, LodAssembleStats* stats = nullptr);

 private:
  gpu::Context& ctx_;
  std::vector<GaussianChunk> chunks_;
  gpu::Buffer fine_rows_, fine_sh_, coarse_rows_, coarse_sh_;
  GpuGaussians frame_;
  std::vector<ChunkPick> picks_;  // what the frame set's static part holds
  bool have_picks_ = false;
  uint32_t static_count_ = 0;
  std::vector<shader::SplatGaussian> extra_rows_;
  std::vector<float> extra_sh_;
  bool extra_dirty_ = true;
};

}  // namespace icube::splat

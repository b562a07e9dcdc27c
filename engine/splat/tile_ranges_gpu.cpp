// The per-tile range stage of the splat binnings; see tile_ranges_gpu.h.
#include "splat/tile_ranges_gpu.h"

#include "shared/splat_params.h"

namespace icube::splat {

void record_tile_ranges(gpu::CommandList& cmd, gpu::Program& ranges_program, const gpu::Buffer& keys,
                        uint32_t key_words, uint64_t instances, const gpu::Buffer& ranges, uint32_t tiles) {
  cmd.fill_buffer(ranges.binding(0, uint64_t{tiles} * 8), 0u);
  cmd.barrier(gpu::deps::kTransferToCompute);  // the ranges kernel writes into the zeroed ranges
  cmd.barrier(gpu::deps::kComputeToCompute);   // ... and reads the sorted keys
  if (instances > 0)
    cmd.dispatch(ranges_program, {instances}, shader::SplatRangesParams{static_cast<uint32_t>(instances), key_words, 0, 0},
                 {keys.binding(0, instances * 4 * key_words), ranges.binding(0, uint64_t{tiles} * 8)});
}

}  // namespace icube::splat

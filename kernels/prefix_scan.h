// Prefix sum (scan) of uint32 arrays of any length, inclusive or exclusive.
//
// Reduce-then-scan over tiles of kTileElements: scan_tile_sums writes one sum
// per tile, the tile sums are scanned recursively (exclusive), and scan_tiles
// rescans every tile with its carry-in. Arrays larger than one storage binding
// are processed as windows (engine/gpu/buffer.h), so the length is limited
// only by the buffer size. Sums wrap modulo 2^32, like std::inclusive_scan on
// uint32_t.
//
// Shaders: shaders/primitives/scan_tile_sums.comp, shaders/primitives/scan_tiles.comp.
// Tests: tests/primitives/test_prefix_scan.cpp. Benchmark: bench/bench_primitives.cpp.
#pragma once

#include "gpu/buffer.h"
#include "gpu/commands.h"

#include <cstdint>
#include <vector>

namespace icube::kernels {

enum class ScanKind { Inclusive, Exclusive };

class PrefixScan {
 public:
  explicit PrefixScan(gpu::Context& ctx);

  // uint32 elements of scratch record() needs for `n` elements (0 when one tile suffices).
  static uint64_t scratch_elements(uint64_t n);

  // Records out[0..n) = scan(in[0..n)). `in` may equal `out`. `scratch` holds
  // at least scratch_elements(n) uint32. The caller makes `in` visible before
  // (a barrier) and puts a barrier after before reading `out`; the passes
  // inside are separated by explicit compute->compute barriers.
  void record(gpu::CommandList& cmd, const gpu::Buffer& in, const gpu::Buffer& out, uint64_t n, ScanKind kind,
              const gpu::Buffer* scratch, uint64_t scratch_offset_elems = 0);

  // Convenience: allocates scratch, submits and waits.
  void run(const gpu::Buffer& in, const gpu::Buffer& out, uint64_t n, ScanKind kind);

 private:
  void record_level(gpu::CommandList& cmd, const gpu::Buffer& in, uint64_t in_offset, const gpu::Buffer& out,
                    uint64_t out_offset, uint64_t n, ScanKind kind, const gpu::Buffer* scratch,
                    uint64_t scratch_offset);
  gpu::Context& ctx_;
  gpu::Program& tile_sums_;
  gpu::Program& tiles_;
};

// Plain-loop CPU reference.
std::vector<uint32_t> prefix_scan_cpu(const std::vector<uint32_t>& in, ScanKind kind);

}  // namespace icube::kernels

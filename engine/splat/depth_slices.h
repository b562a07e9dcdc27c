// A splatting frame in depth slices: for frames whose Gaussians or tile instances do not fit
// one pass of the rasterizer (one storage binding per per-Gaussian buffer: 2.79 M Gaussians,
// 33.5 M instances on lavapipe's 128 MiB), SplatRendererGpu::render cuts the visible
// Gaussians into ranges of their depth sort key, nearest first, each small enough for one
// pass, and blends the slices one after another into the same pixels, each pixel's state
// (colour, transmittance, depth sums) carried from slice to slice (splat/blend.comp
// SPLAT_CARRY_IN / SPLAT_CARRY_OUT). A slice holds its Gaussians in index order, so each
// pixel blends the same Gaussians in the same (depth key, index) order with the same
// operations as one pass over all of them: the same image, bit for bit.
//
// Per frame: splat_slice_keys (each Gaussian's depth sort key or "culled", and its tile rect
// area, an upper bound of its tile instances) and splat_slice_histogram (65,536 buckets of the
// key's high 16 bits: Gaussians and rect tiles) over windows of the input; the host cuts the
// key range into slices under both limits (plan_depth_slices), refining a bucket that is too
// full by a histogram of its own keys. Per slice: splat_slice_flags -> exclusive
// PrefixScan over the frame (the member's place in the slice) -> splat_slice_gather (rows and
// SH rows copied into the slice's buffers), then the rasterizer's one-pass stages on the slice.
// Every binding is a window of at most one storage binding; the frame's size is limited by
// device memory (the input, 12 bytes per Gaussian of keys, areas and flags/places, and one
// slice's copy).
//
// Shaders: shaders/splat/slice_{keys,histogram,flags,gather}.comp. Tests:
// tests/splat/test_depth_slices.cpp. Benchmark: bench/bench_splat.cpp (3 M and 10 M Gaussians).
#pragma once

#include "gpu/buffer.h"
#include "gpu/commands.h"
#include "kernels/prefix_scan.h"
#include "splat/splat_frame.h"

#include <cstdint>
#include <functional>
#include <vector>

namespace icube::splat {

struct GpuGaussians;

// One slice: the visible Gaussians whose depth sort key lies in [key_lo, key_hi].
struct DepthSlice {
  uint32_t key_lo = 0, key_hi = 0;
  uint64_t gaussians = 0;  // members
  uint64_t tiles = 0;      // Σ their tile rect areas (>= their tile instances)
};

// One histogram bucket: Gaussians and Σ rect tiles.
struct SliceBucket {
  uint64_t gaussians = 0;
  uint64_t tiles = 0;
};

// A histogram of the keys in [key_lo, key_hi]: bucket b holds keys key_lo + [b << shift,
// (b + 1) << shift).
struct SliceHistogram {
  uint32_t key_lo = 0, key_hi = 0;
  uint32_t shift = 0;
  std::vector<SliceBucket> buckets;
};

// Cuts the histogram's keys into slices of at most `max_gaussians` Gaussians and `max_tiles`
// rect tiles, in key order. A bucket of several keys over a limit is refined by
// `refine(lo, hi)`, a finer histogram of its keys [lo, hi]; a single key over a limit throws
// std::runtime_error saying how many Gaussians share that depth. Empty buckets make no slice;
// no visible Gaussian gives no slice.
std::vector<DepthSlice> plan_depth_slices(const SliceHistogram& h, uint64_t max_gaussians, uint64_t max_tiles,
                                          const std::function<SliceHistogram(uint32_t, uint32_t)>& refine);

// CPU references of the slice kernels, from the CPU rasterizer's projections (preprocess_cpu):
// splat_slice_keys (each Gaussian's depth sort key or SPLAT_SLICE_CULLED, its rect area),
// splat_slice_histogram (the buckets of keys [h_lo, h_hi] at `shift`, as SliceHistogram) and
// splat_slice_flags + scan + splat_slice_gather (the members of a slice, in index order).
void slice_keys_cpu(const std::vector<shader::SplatProjected>& proj, uint32_t grid_x, uint32_t grid_y,
                    uint32_t key_bits, std::vector<uint32_t>& keys, std::vector<uint32_t>& tiles);
SliceHistogram slice_histogram_cpu(const std::vector<uint32_t>& keys, const std::vector<uint32_t>& tiles,
                                   uint32_t key_lo, uint32_t key_hi, uint32_t shift);
std::vector<uint32_t> slice_members_cpu(const std::vector<uint32_t>& keys, const DepthSlice& s);

class DepthSlicer {
 public:
  explicit DepthSlicer(gpu::Context& ctx);

  // The slices of one frame (two or three submissions): keys and areas of every Gaussian of
  // `g` under `frame` (its preprocess constants) and `key_bits` (SplatOptions::depth_key_bits),
  // their histogram, and a refinement of each over-full bucket.
  std::vector<DepthSlice> plan(const GpuGaussians& g, const SplatFrame& frame, uint32_t key_bits,
                               uint64_t max_gaussians, uint64_t max_tiles);
  // Copies the members of `s` into `out` (grown as needed; origin, degree and SH stride of
  // `g`), in index order (two submissions). Call after plan() on the same frame.
  void gather(const GpuGaussians& g, const DepthSlice& s, GpuGaussians& out);

  uint64_t bytes() const;  // device memory held
  // The planned frame's keys and rect areas (splat_slice_keys' output; tests).
  void download_keys(std::vector<uint32_t>& keys, std::vector<uint32_t>& tiles) const;

 private:
  // The histogram of keys [key_lo, key_hi] in at most 2^bucket_bits_ buckets.
  SliceHistogram histogram(uint32_t key_lo, uint32_t key_hi);
  // Input windows: every per-Gaussian binding of a window (rows, SH rows, keys, areas, flags)
  // fits one storage binding and one texel view, with room for an aligned destination.
  std::vector<gpu::ElementWindow> windows(const GpuGaussians& g) const;

  gpu::Context& ctx_;
  gpu::Program& keys_;
  gpu::Program& hist_;
  gpu::Program& flags_;
  gpu::Program& gather_;
  kernels::PrefixScan scan_;
  std::vector<gpu::ElementWindow> windows_;  // of the planned frame
  uint64_t n_ = 0;                           // its Gaussians
  uint32_t bucket_bits_ = 16;                // histogram resolution: 16 bits, fewer when 3 words x 2^16 exceed a binding
  gpu::Buffer keys_buf_, tiles_buf_, ranks_, scan_scratch_, hist_buf_, readback_;
};

}  // namespace icube::splat

// GPU host module of the tile-based Gaussian splatting rasterizer
// (shaders/splat/preprocess.comp, splat/sorted_counts.comp,
// splat/duplicate.comp, splat/ranges.comp, splat/blend.comp; TileBinningGpu; the
// foundation PrefixScan and 32-bit RadixSort from kernels/). Same rules and outputs as the CPU reference rasterizer_cpu.h.
//
// A frame is three recorded stages (record_preprocess, record_bin, record_blend)
// over one SplatFramePlan (the frame's set-up and sizes) and the renderer's
// SplatFrameBuffers; callers with their own command lists (the viewer, icube
// generate) record them there, render() submits them itself. The instance total
// is read back once between preprocess and binning (it sizes the instance
// buffers), so a frame is two submissions:
//   1. preprocess (one invocation per Gaussian, a pipeline per SH degree, the
//      SH row read as vec4 texels from windows of at most maxStorageBufferRange;
//      also writes the depth keys) -> 32-bit RadixSort of the Gaussians by
//      depth (N keys, 4 passes; 2 with SplatOptions::depth_key_bits = 16, a
//      log-linear code of the depth) -> tiles touched in depth order
//      (splat_sorted_counts, which also writes a depth-ordered SplatBinRecord
//      per Gaussian so that the binning streams instead of gathering by
//      Gaussian index) -> inclusive PrefixScan -> total to the host;
//   Exact tile culling: splat_sorted_counts counts (and splat_duplicate emits)
//   only the rect tiles that the α-cut ellipse reaches (splat/tiles.glsl,
//   rasterizer_cpu.h tile_row_span), which roughly halves the instances.
//   2. duplicate tile ids in depth order at the scan offsets -> stable 32-bit
//      RadixSort of the bits(#tiles) low bits (2 passes up to 65,536 tiles)
//      -> fill ranges 0 -> splat_ranges -> blend (+ sky, sky.h).
//   Binning by tile (SplatGpuVariant::binning): the above is the Radix path
//   (GPUs); on CPU devices (lavapipe) the Counting path of tile_binning_gpu.h
//   replaces splat_duplicate + sort + splat_ranges in submission 2 by a stable
//   counting sort (chunked count walk, scan of the per-(tile, chunk) counters
//   and ranges in splat_bin_offsets, emit walk): the same instance list and ranges in
//   O(instances + tiles·chunks). Should a walk be cut short (lavapipe's loop
//   limit), the frame's submission 2 is redone with the Radix path.
//   Preprocess also writes a 48-byte blend record per Gaussian
//   (SplatBlendRecord: the first two vec4 decide whether a Gaussian can touch
//   a pixel row segment); the blend runs one tile per workgroup: each subgroup
//   loads a batch of 4 records per lane (independent loads), tests each
//   Gaussian's α-cut ellipse against its pixel block's 8-column groups, and
//   per group evaluates only the ballot's needed Gaussians, 4 per loop
//   iteration, in depth order, with the record shuffled from its lane
//   (splat/blend.comp; on CPU devices its ballots and votes are constant-index
//   shuffles). SplatOptions::depth = false selects a blend pipeline without
//   the expected/median depth. Loads at per-lane (divergent or strided)
//   addresses are texel fetches (uniform texel buffers, R32_UINT /
//   R32G32B32A32_UINT, bit-cast in the shader: exact): the Gaussians and SH
//   windows in preprocess, rects/records in splat_sorted_counts, the bin
//   records in the binning walks and splat_duplicate, values/records/sky in the
//   blends. On lavapipe a texel fetch is a gather where a storage-buffer load at
//   a divergent address is a per-lane loop; on NVIDIA/AMD both are ordinary
//   loads. The sky model (SplatOptions::sky, sky.h) is applied in the blend:
//   C + T·sky(d).
//   The result is the reference's (tile, depth, Gaussian index) order of the
//   64-bit keys tile << 32 | depth bits, with 4 + 2 passes over N + instances
//   instead of 6 passes of 64-bit keys over the instances.
// Positions are uploaded relative to a scene origin (the bounding-box centre,
// in double) and the camera position is split against the same origin, so
// scenes far from the world origin render like scenes at it.
// Limits: one pass takes the Gaussians whose per-Gaussian buffers and instance
// keys each fit one storage binding and one texel-buffer view (lavapipe: 2.79 M
// Gaussians, 33.5 M instances; gaussians_per_pass, instances_per_pass); render()
// blends a larger frame in depth slices of at most that size (depth_slices.h),
// the same image, so the Gaussians are limited by device memory. An image whose
// RGBA floats exceed one binding is rendered in bands of tile rows (downloaded
// images only). Images of more than 65,535 tile columns or rows (SplatBinRecord
// packs tile coordinates in 16 bits) fail with a clear message.
// Tests: tests/splat/test_splat.cpp, tests/splat/test_splat_stages.cpp; benchmark: bench/bench_splat.cpp.
#pragma once

#include "gpu/buffer.h"
#include "gpu/commands.h"
#include "kernels/prefix_scan.h"
#include "kernels/radix_sort.h"
#include "splat/depth_slices.h"
#include "splat/gaussians.h"
#include "splat/splat_frame.h"
#include "splat/tile_binning_gpu.h"
#include "splat/tile_radix_binning_gpu.h"

#include <memory>

namespace icube::splat {

struct GpuGaussians {
  gpu::Buffer gaussians;  // SplatGaussian per Gaussian
  gpu::Buffer sh;         // sh_stride floats per Gaussian
  uint32_t count = 0;
  uint32_t sh_degree = 0;
  uint32_t sh_stride = 0;
  glm::dvec3 origin{0.0};
  uint64_t bytes() const { return gaussians.size() + sh.size(); }
};

// The origin upload() puts a cloud's positions against: the bounding-box centre floored to whole
// metres (exact in float for any planet-sized scene); (0, 0, 0) for an empty cloud.
glm::dvec3 gaussian_origin(const GaussianCloud& cloud);
// SH floats per Gaussian on the GPU: 3·(degree + 1)² rounded up to a multiple of 4 (vec4 texels).
uint32_t gpu_sh_stride(uint32_t sh_degree);
// The GPU rows of `cloud` (positions relative to `origin`, covariances) and its SH padded with
// zeros to `sh_stride` floats per Gaussian (>= 3·sh_coeffs(): a higher degree's zero terms).
void pack_gaussians(const GaussianCloud& cloud, const glm::dvec3& origin, uint32_t sh_stride,
                    std::vector<shader::SplatGaussian>& rows, std::vector<float>& sh);

// Phase times of the last frame (GPU timestamps; NaN when unsupported) and its size.
struct SplatTimings {
  double preprocess_ms = 0;  // preprocess
  double depth_sort_ms = 0;  // depth sort of the Gaussians + tiles touched in depth order + scan
  double sort_ms = 0;        // binning: duplicate tile ids + radix sort by tile + ranges, or the counting sort
  double blend_ms = 0;
  double wall_ms = 0;        // host wall clock for the whole frame (both submissions + downloads)
  uint64_t instances = 0;    // (tile, Gaussian) pairs
  uint64_t frame_bytes = 0;  // per-frame GPU buffers currently allocated
  uint32_t binning_chunks = 0;    // counting binning: its chunk count C (0: the radix path binned the frame)
  bool binning_fallback = false;  // the counting walks were cut short and the radix path re-binned the frame
  uint32_t slices = 0;            // depth slices the frame was blended in (depth_slices.h; 0: one pass)
  uint32_t bands = 0;             // bands of tile rows an image over one binding was rendered in (0: whole)
};

// Intermediate results for tests.
struct SplatDebug {
  std::vector<shader::SplatProjected> proj;
  std::vector<uint64_t> keys;    // sorted, as tile << 32 | depth bits of proj[value] (rebuilt on the host)
  std::vector<uint32_t> values;  // sorted
  std::vector<uint32_t> ranges;  // 2 per tile
  bool counting = false;          // the counting binning made the lists (keys' tile ids rebuilt from the ranges)
  bool binning_fallback = false;  // see SplatTimings
};

// How the tile instances are sorted by tile (both give the same list and ranges): Radix =
// splat_duplicate + stable RadixSort of the tile-id bits + splat_ranges; Counting = the
// chunked counting sort of tile_binning_gpu.h; Auto = Counting on CPU devices
// (VK_PHYSICAL_DEVICE_TYPE_CPU: lavapipe), Radix on GPUs.
enum class TileBinning { Auto, Radix, Counting };

// Pipeline variants (for side-by-side benchmarks and tests; the defaults are the fast ones, and
// every variant gives the same images). exact_cull = false bins whole getRect rects
// (TileRule::Rect, more instances); tile_blend = false uses splat/blend_rows.comp (the
// previous blend: 4 tiles per workgroup, per-lane skip loops); bin_chunks > 0 forces the
// counting sort's chunk count (TileBinningGpu::chunks_for; tests).
struct SplatGpuVariant {
  bool exact_cull = true;
  bool tile_blend = true;
  TileBinning binning = TileBinning::Auto;
  uint32_t bin_chunks = 0;
  // splat_blend's loop budget (SplatBlendParams::loop_budget): -1 = SPLAT_BLEND_LOOP_BUDGET on
  // CPU devices (lavapipe's loop limit), none on GPUs; tests force a small one. A frame in
  // which a tile reached it throws std::runtime_error instead of returning a cut-short blend.
  int64_t blend_loop_budget = -1;
  // splat_blend's ballots and votes (kernels/subgroup_ops.h): Auto = constant-index shuffles
  // on CPU devices, the subgroup intrinsics on GPUs; tests force each (Shuffles needs a
  // subgroup of at most 16 lanes that divides the blend's 16 invocations per tile).
  kernels::SubgroupOps votes = kernels::SubgroupOps::Auto;
  // Caps gaussians_per_pass() (0: the device's limits): frames over it are blended in depth
  // slices; the image does not depend on it (benchmarks and tests check slicings against each other).
  uint64_t max_pass_gaussians = 0;
};

// The per-frame device buffers, grown on demand (gpu::ensure_capacity) and reused frame to
// frame; each stage names what it reads and writes.
struct SplatFrameBuffers {
  explicit SplatFrameBuffers(gpu::Context& ctx);
  gpu::Buffer proj;         // SplatProjected per Gaussian (preprocess; tests read it)
  gpu::Buffer records;      // SplatBlendRecord per Gaussian (preprocess -> blend)
  gpu::Buffer rects;        // tile rect per Gaussian (preprocess -> sorted counts)
  gpu::Buffer bin_records;  // SplatBinRecord in depth order (sorted counts -> binning)
  gpu::Buffer depth_keys;   // depth sort keys, then scratch (preprocess -> depth sort)
  gpu::Buffer order;        // Gaussian indices in depth order (depth sort -> binning)
  gpu::Buffer values;       // counting path: Gaussian index per instance, tile-major (-> blend)
  gpu::Buffer ranges;       // [first, end) per tile (binning -> blend)
  gpu::Buffer rgba, depth;  // the image (blend); depth 16 bytes when the blend leaves it out
  gpu::Buffer sky;          // the equirect sky image, uploaded when it changes
  gpu::Buffer incomplete;   // counting path: != 0 when a walk was cut short
  gpu::Buffer blend_status; // blocks over the blend's loop budget
  gpu::Buffer readback;     // host-visible: [0] instances, [1] incomplete, [2] blend status
  gpu::Buffer carry_color, carry_depth;  // a frame in depth slices: each pixel's blend state between slices
  GpuGaussians slice;       // a frame in depth slices: the current slice's Gaussians
  std::shared_ptr<const SkyImage> sky_image;  // the image currently in `sky`
  std::unique_ptr<kernels::RadixSortScratch> depth_sort_scratch;
  TileRadixBinning binning;  // depth-ordered counts -> offsets -> total; radix path: keys/values -> sort -> ranges
  uint64_t bytes() const;
};

// One frame's set-up (SplatRendererGpu::plan): its constants, sizes and binning choice.
struct SplatFramePlan {
  const GpuGaussians* gaussians = nullptr;
  SplatOptions opts;
  SplatFrame frame;
  uint32_t width = 0, height = 0, tiles = 0;
  uint64_t n = 0;
  uint64_t instances = 0;    // read_instances(), after record_preprocess's submission
  bool counting = false;     // this frame bins with the counting sort (record_bin)
  uint32_t chunks = 0;       // its chunk count
  bool fallback = false;     // the counting walks were cut short and the frame was re-binned (radix)
  // The frame's Gaussians (plan) or tile instances (read_instances) exceed one pass: render()
  // blends it in depth slices (depth_slices.h); the stages refuse it.
  bool sliced = false;
  shader::SplatBlendParams blend{};
};

class SplatRendererGpu {
 public:
  explicit SplatRendererGpu(gpu::Context& ctx, SplatGpuVariant variant = {});
  ~SplatRendererGpu();

  GpuGaussians upload(const GaussianCloud& cloud);
  // The binning path this renderer takes (Auto resolved for the device). A Counting renderer
  // still bins a frame with the radix path when the counters would not fit one binding or a
  // walk was cut short (SplatTimings::binning_chunks, binning_fallback).
  TileBinning binning() const { return counting_ ? TileBinning::Counting : TileBinning::Radix; }

  // Renders one frame: the stages below in two submissions. `download` = false skips reading
  // the image back (benchmarks).
  SplatImage render(const GpuGaussians& g, const render::Camera& cam, const SplatOptions& opts,
                    SplatTimings* timings = nullptr, SplatDebug* debug = nullptr, bool download = true);

  // ---- the stages, for callers that record into their own command lists ----
  // The most Gaussians and tile instances one pass takes on this device (one storage binding per
  // per-Gaussian and per-instance buffer, one texel view); render() blends larger frames in
  // depth slices of at most these sizes.
  uint64_t gaussians_per_pass() const;
  uint64_t instances_per_pass() const;

  // Checks the frame against the device limits and sizes the per-Gaussian buffers (host only);
  // a frame over one pass is marked p.sliced and sizes nothing per Gaussian.
  SplatFramePlan plan(const GpuGaussians& g, const render::Camera& cam, const SplatOptions& opts);
  // preprocess -> depth sort -> tiles touched in depth order -> scan -> instance total copied
  // to the host. The caller submits and waits before read_instances.
  void record_preprocess(gpu::CommandList& cmd, const SplatFramePlan& p);
  // The instance total of the completed preprocess submission; sizes the binning buffers and
  // picks the frame's binning path (p.counting, p.chunks), or marks p.sliced when the instances
  // exceed one pass.
  uint64_t read_instances(SplatFramePlan& p);
  // Binning by tile (counting sort or the radix path) into buffers().ranges and the instance
  // list, then a barrier for the blend.
  void record_bin(gpu::CommandList& cmd, const SplatFramePlan& p);
  // The blend into buffers().rgba / depth, and its status copied to the host.
  void record_blend(gpu::CommandList& cmd, const SplatFramePlan& p);
  // After the binning + blend submission: false when the counting walks were cut short (then
  // set p.counting = false, re-record record_bin + record_blend and submit again). Throws when
  // a blend block reached the loop budget (the image would be incomplete).
  bool finish(SplatFramePlan& p);
  const SplatFrameBuffers& buffers() const { return *f_; }
  // The instance list the blend reads: the counting path's values or the radix path's.
  const gpu::Buffer& instance_values(const SplatFramePlan& p) const;

 private:
  // Timings accumulated over a frame's submissions.
  struct PassTimes {
    double preprocess_ms = 0, depth_sort_ms = 0, sort_ms = 0, blend_ms = 0;
    uint64_t instances = 0;
    bool fallback = false;
  };
  // Submission 1 of a planned pass (preprocess -> instance total).
  void run_preprocess(SplatFramePlan& p, PassTimes& t, bool after_gather);
  // Submission 2 (binning + blend), again with the radix path when the counting walks were cut short.
  void run_bin_blend(SplatFramePlan& p, PassTimes& t);
  // An image whose RGBA floats exceed one binding: bands of whole tile rows, each a frame of its
  // own with the principal point moved (the same pixels up to float rounding of the projected
  // means, ~1e-5 px), stitched on the host.
  SplatImage render_bands(const GpuGaussians& g, const render::Camera& cam, const SplatOptions& opts,
                          SplatTimings* timings, SplatDebug* debug, bool download);
  // A frame over one pass: its depth slices one after another into buffers().rgba / depth.
  uint32_t run_slices(const GpuGaussians& g, const render::Camera& cam, const SplatOptions& opts, PassTimes& t);

  gpu::Context& ctx_;
  gpu::Program& counts_;
  gpu::Program& duplicate_;
  gpu::Program& ranges_;
  gpu::Program& blend_;
  gpu::Program& blend_color_;  // splat_blend without the depth outputs (SplatOptions::depth = false)
  SplatGpuVariant variant_;
  bool counting_;  // the resolved TileBinning
  kernels::RadixSort depth_sort_;
  TileBinningGpu counting_binning_;
  DepthSlicer slicer_;
  // render_bands: the band of tile rows [band_y0_, band_y0_ + band_rows_) being rendered (0 rows: whole images).
  uint32_t band_y0_ = 0, band_rows_ = 0;
  std::unique_ptr<SplatFrameBuffers> f_;
  std::unique_ptr<gpu::GpuTimer> t1_, t2_;  // preprocess + depth sort; binning + blend
};

}  // namespace icube::splat

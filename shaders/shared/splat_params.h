// Push constants and per-Gaussian records of the Gaussian splatting
// rasterizer (shaders/splat_*.comp; host module engine/splat/rasterizer_gpu.h,
// CPU reference engine/splat/rasterizer_cpu.h). Shared by GLSL and C++.
//
// Inputs per Gaussian: SplatGaussian (position relative to the scene origin,
// activated opacity, Σ as 6 floats) and a row of sh_stride floats of raw SH
// coefficients (k-major, then RGB). The camera position is relative to the same
// scene origin (split on the host in double), so scenes far from the world
// origin render like scenes at it.
#ifndef ICUBE_SPLAT_PARAMS_H
#define ICUBE_SPLAT_PARAMS_H
#include "gpu_types.h"

#define SPLAT_TILE 16
#define SPLAT_TILE_PIXELS 256
// splat/blend.comp: pixels of one tile row per invocation (register tile);
// SPLAT_TILE_PIXELS / SPLAT_BLEND_PIXELS invocations per tile.
#ifndef SPLAT_BLEND_PIXELS
#define SPLAT_BLEND_PIXELS 16
#endif
// Exact tile culling (shaders/splat/tiles.glsl, rasterizer_cpu.h
// tile_row_span): tile t spans pixels [16t - M, 16t + 16 + M] in the
// ellipse-against-tile test, M = SPLAT_CULL_MARGIN px (covers both pixel
// conventions' samples 16t + o .. 16t + 15 + o with at least 0.5 px to spare).
#define SPLAT_CULL_MARGIN 0.5
// The blend's loop budget on CPU devices (lavapipe: gallivm's LP_MAX_TGSI_LOOP_ITERATIONS =
// 65,535 loop iterations per invocation, all loops together), with a margin for the
// iterations the kernel does not count.
#define SPLAT_BLEND_LOOP_BUDGET 64000u

ICUBE_SHADER_NAMESPACE_BEGIN

// std430, 48 bytes (three vec4).
struct SplatGaussian {
  float px, py, pz;  // metres, relative to the scene origin
  float opacity;     // sigmoid(raw)
  float c00, c01, c02, c11, c12, c22;  // Σ (world), metres²
  float pad0, pad1;
};

// Result of preprocessing, 48 bytes. radius == 0 marks a culled Gaussian.
struct SplatProjected {
  float mean_x, mean_y;  // pixels: fx·x/z + cx, fy·y/z + cy
  float depth;           // view z (metres)
  float opacity;         // opacity · antialiasing compensation
  float conic_x, conic_y, conic_z;  // inverse 2-D covariance (a', b', c')
  float radius;                     // pixels (integer valued)
  float r, g, b;                    // SH colour + 0.5, clamped at 0
  float pad;
};

// What splat_blend reads per Gaussian, written by splat_preprocess, 48 bytes:
// the first two vec4 are enough to decide whether the Gaussian can reach
// α >= 1/255 on a pixel row segment, the third holds the colour.
struct SplatBlendRecord {
  float mean_x, mean_y, conic_x, conic_y;
  float conic_z;
  float log_cut;  // ln(0.9 / (255·opacity)): power below it cannot give α >= 1/255 (10 % margin)
  float opacity, depth;
  float r, g, b, pad;
};

// Depth-ordered binning record, 32 bytes (two uvec4): splat_sorted_counts writes one per
// depth position j (of Gaussian order[j]); the binning walks (splat_bin_chunks) and
// splat_duplicate read them in j order, so their per-Gaussian reads stream instead of
// gathering records by Gaussian index (whose cache misses made the counting binning take
// twice as long; bench/README.md). Packed and read by
// splat/tiles.glsl.
struct SplatBinRecord {
  float mean_x, mean_y, conic_x, conic_y;  // as SplatBlendRecord
  float conic_z, log_cut;
  uint rect_x;  // tile rect columns x0 | x1 << 16 (zero when culled)
  uint rect_y;  // tile rect rows y0 | y1 << 16
};

// 16-bit depth sort keys (SplatOptions::depth_key_bits = 16): the float's exponent and top 11
// mantissa bits, offset so that z in [2^-16, 2^16) m maps to [0, 65535] (clamped; culled z = 0 -> 0):
//   key = clamp(int(floatBits(z) >> 12) - (111 << 11), 0, 65535)
// a monotonic log-linear code, 2048 steps per octave (relative depth step <= 2^-11); the same
// integer operations on the host (splat_frame.h depth_key16) and in splat/preprocess.comp.
#define SPLAT_DEPTH_KEY16_OFFSET (111 << 11)

struct SplatPreprocessParams {
  uint n;          // Gaussians in this window
  uint first;      // index of the window's first Gaussian
  uint sh_stride;  // floats per Gaussian in the SH binding
  uint depth_key16;  // 1: 16-bit depth sort keys (SPLAT_DEPTH_KEY16), 0: the float bits of view z
  float r00, r01, r02, r10, r11, r12, r20, r21, r22;  // world-to-camera rotation (row-major)
  float cam_x, cam_y, cam_z;                          // camera position relative to the scene origin
  float fx, fy, cx, cy;
  float lim_x_pos, lim_x_neg, lim_y_pos, lim_y_neg;  // Jacobian clamp on x/z and y/z
  float near_z, far_z, eps2d;
  uint antialiased;
  // The tile rect rows are clamped to the band [tile_y0, tile_y0 + grid_y) of the whole image's
  // tile rows (a whole image: 0 and all rows); rects keep whole-image rows, tile ids count from
  // the band's first row (engine/splat/rasterizer_gpu.h, render_bands).
  uint width, tile_y0, grid_x, grid_y;
};

struct SplatDuplicateParams {
  uint n;  // Gaussians
  uint grid_x;
  uint cull;  // 1: exact tile culling (splat/tiles.glsl), 0: whole tile rects
  uint tile_y0;  // the band's first tile row: tile id = (row - tile_y0) · grid_x + column
};

// splat/bin_chunks.comp / splat/bin_offsets.comp (the counting-sort tile
// binning, engine/splat/tile_binning_gpu.h).
struct SplatBinParams {
  uint n;          // Gaussians (depth-sorted positions)
  uint grid_x;
  uint chunks;     // C: chunks of the instance list = counters per tile (chunk-major: counter chunk · tiles + tile)
  uint chunk_len;  // instances per chunk: chunk c = [c · chunk_len, min(instances, (c + 1) · chunk_len))
  uint cull;       // 1: exact tile culling (splat/tiles.glsl), 0: whole tile rects
  uint tiles;      // grid_x · grid_y
  uint instances;  // tile instances of the frame (the last inclusive offset)
  uint tile_y0;    // the band's first tile row: tile id = (row - tile_y0) · grid_x + column
};

// splat/to_rgba8.comp
struct SplatToRgba8Params {
  uint pixels;
  uint pad0, pad1, pad2;
};

struct SplatRangesParams {
  uint n;          // instances (sorted keys)
  uint key_words;  // uint32 words per key, the tile id in the last: 1 (rasterizer tile ids) or 2 (LiDAR 64-bit keys)
  uint pad1, pad2;
};

#define SPLAT_SKY_BACKGROUND 0u  // constant background colour
#define SPLAT_SKY_GRADIENT 1u    // zenith / horizon / ground by the world z of the ray
#define SPLAT_SKY_EQUIRECT 2u    // equirectangular RGBA8 image (engine/splat/sky.h)

// 128 bytes. Sky model (engine/splat/sky.h): pixel ray direction in world axes
// d = normalize(M · (u + o, v + o, 1)), M = R_c2w · K⁻¹ (row-major m00..m22).
struct SplatBlendParams {
  uint width, height, grid_x, grid_y;
  float pixel_offset;  // pixel (u, v) is sampled at (u + o, v + o)
  uint sky_kind;       // SPLAT_SKY_*
  uint sky_w, sky_h;   // equirect image size (texels)
  float bg_r, bg_g, bg_b;     // background (SPLAT_SKY_BACKGROUND)
  float zen_r, zen_g, zen_b;  // gradient: straight up (+z)
  float hor_r, hor_g, hor_b;  // gradient: horizon
  float gnd_r, gnd_g, gnd_b;  // gradient: straight down
  float m00, m01, m02, m10, m11, m12, m20, m21, m22;
  // splat/blend.comp: a workgroup whose loops made at least this many iterations counts itself
  // in the status word (0 = no budget). lavapipe ends every loop of an invocation once its
  // loops have made 65,535 iterations in all, so the host sets SPLAT_BLEND_LOOP_BUDGET there.
  uint loop_budget;
  // Depth slices (engine/splat/depth_slices.h): SPLAT_CARRY_IN starts every pixel from the
  // previous slice's state in the carry buffers instead of empty; SPLAT_CARRY_OUT stores the
  // state there for the next slice instead of writing the image. 0 = a whole frame.
  uint carry;
  // A band of tile rows [tile_y0, tile_y0 + grid_y) of a larger image (height: the whole
  // image's): pixel rows are the whole image's, written from row 16 tile_y0 of the band's
  // buffers. A whole image: 0.
  uint tile_y0;
};

#define SPLAT_CARRY_IN 1u
#define SPLAT_CARRY_OUT 2u

// splat/slice_keys.comp, splat/slice_histogram.comp, splat/slice_flags.comp and
// splat/slice_gather.comp (a frame in depth slices, engine/splat/depth_slices.h). The slice
// key of a Gaussian is its depth sort key, SPLAT_SLICE_CULLED when preprocess culls it.
#define SPLAT_SLICE_CULLED 0xFFFFFFFFu
struct SplatSliceParams {
  uint n;               // Gaussians in this window
  uint key_lo, key_hi;  // keys in [key_lo, key_hi]: the slice (flags, gather) or the histogram's range
  uint shift;           // histogram: bucket = (key - key_lo) >> shift
  uint sh_texels;       // gather: vec4 texels per Gaussian's SH row
  uint dst_first;       // gather: slice rank of the destination bindings' first Gaussian
  uint bucket_first;    // histogram: the bound window of buckets [bucket_first, + bucket_count)
  uint bucket_count;
};

ICUBE_SHADER_NAMESPACE_END

ICUBE_CHECK_SIZE(SplatGaussian, 48);
ICUBE_CHECK_LAYOUT(SplatGaussian, opacity, 12);
ICUBE_CHECK_LAYOUT(SplatGaussian, c00, 16);
ICUBE_CHECK_SIZE(SplatProjected, 48);
ICUBE_CHECK_LAYOUT(SplatProjected, opacity, 12);
ICUBE_CHECK_LAYOUT(SplatProjected, conic_x, 16);
ICUBE_CHECK_LAYOUT(SplatProjected, radius, 28);
ICUBE_CHECK_LAYOUT(SplatProjected, r, 32);
ICUBE_CHECK_SIZE(SplatBlendRecord, 48);
ICUBE_CHECK_LAYOUT(SplatBlendRecord, conic_z, 16);
ICUBE_CHECK_LAYOUT(SplatBlendRecord, r, 32);
ICUBE_CHECK_SIZE(SplatBinRecord, 32);
ICUBE_CHECK_LAYOUT(SplatBinRecord, conic_z, 16);
ICUBE_CHECK_LAYOUT(SplatBinRecord, rect_x, 24);
ICUBE_CHECK_LAYOUT(SplatBinRecord, rect_y, 28);
ICUBE_CHECK_SIZE(SplatPreprocessParams, 128);
ICUBE_CHECK_LAYOUT(SplatPreprocessParams, r00, 16);
ICUBE_CHECK_LAYOUT(SplatPreprocessParams, cam_x, 52);
ICUBE_CHECK_LAYOUT(SplatPreprocessParams, fx, 64);
ICUBE_CHECK_LAYOUT(SplatPreprocessParams, lim_x_pos, 80);
ICUBE_CHECK_LAYOUT(SplatPreprocessParams, near_z, 96);
ICUBE_CHECK_LAYOUT(SplatPreprocessParams, width, 112);
ICUBE_CHECK_SIZE(SplatDuplicateParams, 16);
ICUBE_CHECK_SIZE(SplatSliceParams, 32);
ICUBE_CHECK_LAYOUT(SplatSliceParams, dst_first, 20);
ICUBE_CHECK_SIZE(SplatBinParams, 32);
ICUBE_CHECK_LAYOUT(SplatBinParams, chunks, 8);
ICUBE_CHECK_LAYOUT(SplatBinParams, tiles, 20);
ICUBE_CHECK_LAYOUT(SplatBinParams, instances, 24);
ICUBE_CHECK_SIZE(SplatRangesParams, 16);
ICUBE_CHECK_SIZE(SplatToRgba8Params, 16);
ICUBE_CHECK_SIZE(SplatBlendParams, 128);
ICUBE_CHECK_LAYOUT(SplatBlendParams, tile_y0, 124);
ICUBE_CHECK_LAYOUT(SplatBlendParams, pixel_offset, 16);
ICUBE_CHECK_LAYOUT(SplatBlendParams, sky_h, 28);
ICUBE_CHECK_LAYOUT(SplatBlendParams, bg_r, 32);
ICUBE_CHECK_LAYOUT(SplatBlendParams, gnd_r, 68);
ICUBE_CHECK_LAYOUT(SplatBlendParams, m00, 80);
ICUBE_CHECK_LAYOUT(SplatBlendParams, loop_budget, 116);
ICUBE_CHECK_LAYOUT(SplatBlendParams, carry, 120);

#endif

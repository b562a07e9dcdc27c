// Push constants of the network layer's kernels (shaders/nn/*.comp,
// kernels/nn/*.cpp).
#ifndef ICUBE_NN_PARAMS_H
#define ICUBE_NN_PARAMS_H
#include "gpu_types.h"

// conv3d register tile: each invocation computes NN_CONV_CO_TILE output
// channels at a run of NN_CONV_ZRUN consecutive voxels along z (neighbouring
// invocations hold neighbouring runs, so a warp's / SIMD row's loads of one
// input row cover contiguous memory).
#define NN_CONV_GROUP 64
#define NN_CONV_ZRUN 8
#define NN_CONV_CO_TILE 8

// conv3d on discrete GPUs (conv3d_tiled*.comp): a shared-memory implicit GEMM
// with M = voxels, N = output channels, K = input channels x taps. A workgroup
// of NN_CONV_TILED_GROUP threads computes an NN_CONV_TILED_BM x NN_CONV_TILED_BN
// block, each thread a 4 x 4 register micro-tile, over K in double-buffered
// steps of NN_CONV_TILED_BK.
#define NN_CONV_TILED_GROUP 256
#define NN_CONV_TILED_BM 64
#define NN_CONV_TILED_BN 64
#define NN_CONV_TILED_BK 16
// The cooperative-matrix form (conv3d_coopmat*.comp): 4 subgroups of 32, each
// a 32 x 32 quarter of the 64 x 64 block as 2 x 2 fragments of 16 x 16 x 16
// (fp16 A and B, fp32 accumulators), K in steps of NN_CONV_COOP_BK.
#define NN_CONV_COOP_GROUP 128
#define NN_CONV_COOP_BM 64
#define NN_CONV_COOP_BN 64
#define NN_CONV_COOP_BK 32

ICUBE_SHADER_NAMESPACE_BEGIN

// conv3d: dense NCDHW float32, stride 1, padding kernel / 2 (sizes kept).
// One dispatch covers `batch` batch elements, output channels
// [co_begin, co_begin + co_count) and input channels [ci_begin, ci_begin +
// ci_count): tensors larger than one storage binding are split into such
// windows by the host, each bound at an aligned offset; *_offset are the
// remaining element offsets inside the bound ranges. accumulate = 1 adds to y
// (later input-channel windows) instead of writing acc + bias.
// Workgroup g: voxel tile g % voxel_tiles, then channel block, then batch.
struct Conv3dParams {
  uint batch;
  uint in_channels;   // the whole tensor's (weight layout)
  uint co_begin;      // multiple of NN_CONV_CO_TILE
  uint co_count;
  uint ci_begin;
  uint ci_count;
  uint co_blocks;     // ceil(co_count / NN_CONV_CO_TILE) (tiled paths: / 64)
  uint co_vec4s;      // packed weight row length in vec4s: ceil(out_channels / 8) * 2
  uint size_x;
  uint size_y;
  uint size_z;
  uint kernel;        // 1 or 3 (the pipeline is specialised on it: NN_K)
  uint voxel_tiles;   // register path: ceil(X * Y * ceil(Z / NN_CONV_ZRUN) / NN_CONV_GROUP);
                      // tiled and cooperative-matrix paths: ceil(X * Y * Z / 64)
  uint has_bias;
  uint accumulate;
  uint x_offset;      // elements: channel ci_begin of the first batch element
  uint x_batch_stride;
  uint y_offset;      // elements: channel co_begin of the first batch element
  uint y_batch_stride;
  uint w_ci_base;     // the first input channel of the bound weight window (0: all weights bound)
};

// conv2d: dense NCHW float32, any kernel kh x kw, stride, zero padding
// (PyTorch's Conv2d): the GSM's image networks. Each invocation computes
// NN_CONV_CO_TILE output channels at NN_CONV2D_XRUN consecutive output
// columns; windows of batch elements, output and input channels as conv3d's.
// Workgroup g: pixel tile g % pixel_tiles, then channel block, then batch.
#define NN_CONV2D_GROUP 64
#define NN_CONV2D_XRUN 4
struct Conv2dParams {
  uint batch;
  uint in_channels;   // the whole tensor's (weight layout)
  uint co_begin;      // multiple of NN_CONV_CO_TILE
  uint co_count;
  uint ci_begin;
  uint ci_count;
  uint co_blocks;     // ceil(co_count / NN_CONV_CO_TILE)
  uint co_vec4s;      // packed weight row length in vec4s: ceil(out_channels / 8) * 2
  uint in_h;
  uint in_w;
  uint out_h;
  uint out_w;
  uint kernel_h;
  uint kernel_w;
  uint stride;
  uint padding;
  uint pixel_tiles;   // ceil(out_h * ceil(out_w / NN_CONV2D_XRUN) / NN_CONV2D_GROUP)
  uint has_bias;
  uint accumulate;
  uint x_offset;      // elements: channel ci_begin of the first batch element
  uint x_batch_stride;
  uint y_offset;      // elements: channel co_begin of the first batch element
  uint y_batch_stride;
  uint w_ci_base;     // the first input channel of the bound weight window (0: all weights bound)
};

// group_norm_partials / group_norm_stats / group_norm_apply: GroupNorm over
// NCDHW float32 with fp32 statistics. A group's channels are contiguous
// (count = channels / groups * spatial elements); partials: `chunks` Welford
// triples (mean, M2, count, shift) per (batch, group), chunk c taking elements c,
// c + chunks, ..., of x minus the group's first element; stats: (shift,
// mean - shift, 1 / sqrt(var + eps), 0) per (batch, group).
#define NN_GN_GROUP 64
#define NN_GN_FLAG_SILU 1u
#define NN_GN_FLAG_MODULATE 2u  // y * (1 + scale[b, c]) + shift[b, c], modulation [B, 2C] = (scale, shift)
// partials: continue the Welford triples already in the partials buffer (a group split over windows:
// the window holds elements [span_begin, span_end) of one group; the shift comes from partial .w).
#define NN_GN_FLAG_CONTINUE 4u

struct GroupNormParams {
  uint batch;           // in this dispatch (one window: 1)
  uint channels;        // in this dispatch
  uint groups;          // in this dispatch
  uint spatial;
  uint chunks;          // partials per (batch, group)
  float eps;
  uint flags;
  uint x_offset;        // elements: the window's first element inside the x binding
  uint y_offset;        // elements: the same inside the y binding
  uint channel_offset;  // the window's first channel in the whole tensor (weight, bias, modulation)
  uint channels_total;  // the whole tensor's channels (modulation rows)
  uint batch_offset;    // the window's batch element (modulation rows)
  uint span_begin;      // elements of the group (partials) or of the window's channels (apply) this
  uint span_end;        //   dispatch covers: [0, C/G * S) and [0, C * S) for whole groups
  uint pad0;
  uint pad1;
};

// elementwise: one thread per output element. OP_SILU y = a / (1 + e^-a);
// OP_ADD y = a + b; OP_GEGLU on channels-first [batch, 2F, n]: y[b, f, t] =
// a[b, f, t] * gelu(a[b, F + f, t]) (exact erf GELU; F = channels).
#define NN_EW_GROUP 64
#define NN_EW_SILU 0u
#define NN_EW_ADD 1u
#define NN_EW_GEGLU 2u
#define NN_EW_GATE_GELU 3u  // y = a * gelu(b): GEGLU over windows (a the value half, b the gate half)
#define NN_EW_GELU 4u       // y = gelu(a), exact (erf)
#define NN_EW_RELU 5u       // y = max(a, 0)
// resample: NN_RS_AVGPOOL2 (2x2x2 mean, sizes floored) or NN_RS_UPSAMPLE2
// (nearest x2) of [batch * channels, X, Y, Z] (input sizes given).
#define NN_RS_AVGPOOL2 0u
#define NN_RS_UPSAMPLE2 1u

struct ElementwiseParams {
  uint count;     // output elements
  uint op;
  uint channels;  // GEGLU: output channels F
  uint tokens;    // GEGLU: elements per channel
  uint a_offset;  // elements: each operand's first element inside its binding (windows)
  uint b_offset;
  uint y_offset;
  uint pad0;
};

// ddim_step: one DDIM step on v-prediction (engine/diffusion/ddim_schedule.h),
// optionally with classifier-free guidance v = cond + cfg_scale (cond - uncond)
// and the step's noise sigma z. latent_overwrite: outpainting's known cells,
// x = sqrt_alpha known + sqrt_beta z where mask[voxel] != 0 (element i is
// voxel i % spatial of its channel).
#define NN_DDIM_GROUP 64
#define NN_DDIM_FLAG_CFG 1u
#define NN_DDIM_FLAG_NOISE 2u

struct DdimStepParams {
  uint count;
  uint flags;
  float cfg_scale;
  float sqrt_alpha;       // sqrt(a_t)
  float sqrt_beta;        // sqrt(1 - a_t)
  float sqrt_alpha_prev;  // sqrt(a_prev)
  float direction;        // sqrt(max(0, 1 - a_prev - sigma^2))
  float sigma;
  uint offset;            // element offset of the window inside every binding (element_window)
};

// dpm_solver_step: one DPM-Solver++ (2M) step on a v-prediction (kernels/nn/dpm_solver_step.h):
//   v = cond (+ cfg_scale (cond - uncond)); x0 = alpha_t x - sigma_t v;
//   out = c_x x + c_0 x0 (+ c_1 x0_prev with NN_DPM_FLAG_SECOND_ORDER); x0_out = x0.
#define NN_DPM_GROUP 64
#define NN_DPM_FLAG_CFG 1u
#define NN_DPM_FLAG_SECOND_ORDER 2u

struct DpmSolverStepParams {
  uint count;
  uint flags;
  float cfg_scale;
  float alpha_t;  // sqrt(a_t)
  float sigma_t;  // sqrt(1 - a_t)
  float c_x;
  float c_0;
  float c_1;
  uint offset;    // element offset of the window inside every binding (element_window)
};

struct LatentOverwriteParams {
  uint count;    // elements of this window
  uint spatial;  // voxels per channel (the mask's length)
  float sqrt_alpha;
  float sqrt_beta;
  uint first;    // the window's first element of the latent (its voxel: (first + i) % spatial)
  uint offset;   // its element offset inside the x, known and noise bindings (element_window)
  uint mask_base;  // the voxel the mask binding starts at (0: the whole mask; a mask window otherwise)
  uint pad0;
};

struct ResampleParams {
  uint planes;  // batch * channels
  uint size_x;  // input sizes
  uint size_y;
  uint size_z;
  uint op;
  uint x_offset;  // elements: the first plane's first element inside each binding (windows)
  uint y_offset;
  uint pad0;
};

// attention: softmax(q k^T * scale) v per (batch, head) on channels-first
// tensors: element (b, h, d, t) of q is q[b * in_batch_stride + q_offset +
// (h * head_dim + d) * tokens + t] (same for k, v; so one qkv buffer chunked
// into thirds works as three views), out[b * out_batch_stride + (h * head_dim
// + d) * tokens + t]. One thread per (batch, head, query); online softmax in fp32.
#define NN_ATTN_GROUP 64
#define NN_ATTN_MAX_HEAD_DIM 128  // a multiple of 8
// Loop iterations one attention invocation may make on CPU devices (lavapipe's
// gallivm: 65,535 in all per invocation), with a margin.
#define NN_ATTN_LOOP_BUDGET 60000u
// attention_tiled (GPUs): a workgroup of NN_ATTN_TILED_GROUP threads takes
// NN_ATTN_TILED_GROUP / 4 queries of one (batch, head), four threads (a quad)
// per query, each holding every fourth head dimension; keys and values stream
// through shared memory NN_ATTN_TILED_KEYS at a time.
#define NN_ATTN_TILED_GROUP 256
#define NN_ATTN_TILED_KEYS 32

struct AttentionParams {
  uint batch;
  uint heads;
  uint head_dim;
  uint tokens;
  uint q_offset;
  uint k_offset;
  uint v_offset;
  uint in_batch_stride;
  uint out_batch_stride;
  float scale;
  uint pad0;
  uint pad1;
};

// layer_norm: LayerNorm over the channels of every token of a
// channels-first [batch, channels, tokens] tensor (the transformer's tokens
// kept in the UNet's NCDHW layout), biased variance, eps inside the sqrt.
#define NN_LN_GROUP 64

struct LayerNormParams {
  uint batch;
  uint channels;
  uint tokens;
  float eps;
};

// Sparse voxel tensors on the GPU: coordinates int32 [N][3], features
// channel-major [C][N] (so a sparse tensor is a dense [1, C, N, 1, 1] one for
// GroupNorm, SiLU, add and 1x1 convolutions, and its channel windows are
// contiguous). sparse_hash_insert: open-addressing table of `table_size`
// (a power of two) uint slots, slot = row + 1 (0 empty), linear probing from
// icube_ijk_hash(ijk) & (table_size - 1); keys are compared on the full ijk.
// sparse_kernel_map: one thread per (row, tap): kmap[row * 27 + tap] = the
// row at ijk + (a, b, c) - 1, tap = (a * 3 + b) * 3 + c, or -1.
#define NN_SPARSE_GROUP 64
#define NN_SPARSE_TAPS 27

struct SparseHashParams {
  uint rows;        // hashed rows (insert, lookup: queries)
  uint table_size;
  uint row_begin;   // sparse_kernel_map: this dispatch's first row (kmap windows)
  uint row_count;   // sparse_kernel_map: rows in this dispatch; kmap entry (row - row_begin) * 27 + tap
};

// sparse_conv: submanifold 3^3 convolution as an output-stationary gather
// over the kernel map. Each invocation holds NN_SPARSE_ROWS consecutive rows x
// NN_CONV_CO_TILE output channels; weights packed as conv3d's
// ([ci * 27 + tap][co padded to 8], grid-order taps). Windows as conv3d:
// output channels [co_begin, co_begin + co_count), input channels
// [ci_begin, ci_begin + ci_count) bound at x_offset / y_offset; accumulate = 1
// adds to y; with fp16 weights co_begin is a multiple of 8 and the window's
// channels start co_lead after it (windows of 4 channels when 8 channel planes
// exceed one binding). Rows [row_begin, row_begin + row_count) per dispatch, their
// kernel-map rows bound from row_begin (kernel maps beyond one binding run in
// row windows). Workgroup g: row tile g % row_tiles, channel block g / row_tiles.
#define NN_SPARSE_ROWS 16

struct SparseConvParams {
  uint rows;
  uint co_begin;
  uint co_count;
  uint ci_begin;
  uint ci_count;
  uint co_blocks;
  uint co_vec4s;   // packed weight row length in vec4s
  uint row_tiles;  // ceil(row_count / (NN_SPARSE_ROWS * NN_SPARSE_GROUP))
  uint has_bias;
  uint accumulate;
  uint x_offset;
  uint y_offset;
  uint row_begin;
  uint row_count;
  uint silu;  // 1: y = silu(result) on store (the last input-channel window; the VAE's conv -> SiLU)
  uint w_ci_base;  // the first input channel of the bound weight window (0: all weights bound)
  uint co_lead;    // computed channels before the window's first: co_begin is rounded down to a whole fp16
                   // weight vector (8 channels) and the window starts co_lead (0 or 4) channels later
  uint pad0, pad1, pad2;
};

// Sparse grid construction (kernels/nn/sparse_grid.h):
// sparse_keep      keep[r] = logits[r] > logits[rows + r] (structure logits
//                  channel-major [2][rows]: 0 = exists), as uint 0/1
// sparse_children  one thread per (parent, child o): a kept parent r (incl =
//                  inclusive scan of keep) writes child (incl[r] - 1) * F + o,
//                  F = fx * fy * fz, o = (a * fy + b) * fz + c: its ijk
//                  ijk[r] * f + (a, b, c), its parent r and its brick-order key
// sparse_permute   out[i] = in[perm[i]] for the children's ijk and parents
// sparse_gather_rows  y[c][i] = rows[i] >= 0 ? x[c][rows[i]] : 0
// The brick-order key of a coordinate (|c| < 2^20 on every axis): u = c + 2^20,
// key = (u.i >> 3) << 45 | (u.j >> 3) << 27 | (u.k >> 3) << 9 | (u.i & 7) << 6
// | (u.j & 7) << 3 | (u.k & 7): ascending keys = brick order (sparse_cpu.h).
#define NN_SPARSE_COORD_LIMIT (1 << 20)

// Max pooling onto the coarsened grid (the VAE encoder's [2,2,1] / [2,2,2]):
// sparse_coarse_keys  key[r] = brick-order key of floor(ijk[r] / f), value r
//                     (then the 64-bit radix sort)
// sparse_segments     starts[i] = 1 where the sorted key differs from the
//                     previous one (i = 0 included), else 0
// sparse_coarse_rows  for each sorted i with starts[i] = 1 (incl = inclusive
//                     scan of starts): coarse row incl[i] - 1 begins at i, its
//                     ijk floor(ijk[perm[i]] / f)
// sparse_max_pool     y[c][q] = max over the sorted fine rows of coarse row q
//                     (segment [begin[q], begin[q + 1]) of perm) of x[c][row]
// sparse_lookup       rows[i] = the row of query ijk i in a hashed grid, or -1
struct SparseGridParams {
  uint rows;      // parents (keep, children); outputs (permute, gather)
  uint in_rows;   // gather: rows of x
  uint channels;  // gather
  uint factor_x;
  uint factor_y;
  uint factor_z;
  uint x_offset;   // gather: elements, windows; keep: channel 0's logits window
  uint y_offset;   // gather, keep: the output window
  uint x1_offset;  // keep: channel 1's logits window
};

// interpolate: F.interpolate of [planes = batch * channels, in_h, in_w]
// float32 maps to [planes, out_h, out_w] by output size (no antialiasing),
// one thread per output element. A source position is exact in integers:
// (dst + 0.5) in / out - 0.5 = ((2 dst + 1) in - out) / (2 out), or with
// align_corners dst (in - 1) / (out - 1) (0 when out = 1), then its floor and
// fraction. NN_INTERP_NEAREST: floor(dst in / out); BILINEAR: the position
// clamped at 0, taps floor and floor + 1 (clamped to the map); BICUBIC: Keys'
// cubic with a = -0.75 on taps floor - 1 .. floor + 2, border-clamped.
#define NN_INTERP_GROUP 64
#define NN_INTERP_NEAREST 0u
#define NN_INTERP_BILINEAR 1u
#define NN_INTERP_BICUBIC 2u

struct InterpolateParams {
  uint planes;         // in this dispatch (a window of whole planes)
  uint in_h;
  uint in_w;
  uint out_h;
  uint out_w;
  uint mode;
  uint align_corners;
  uint x_offset;       // elements: the window's first plane inside the x binding
  uint y_offset;       // the same inside the y binding
};

// batch_norm: inference BatchNorm as a per-channel affine y = act(x scale[c] +
// shift[c]) over [batch, channels, spatial] float32, one thread per element;
// act = NN_BN_ACT_*. A dispatch covers `count` consecutive elements (a flat
// window) starting at spatial position first_spatial of channel first_channel.
#define NN_BN_GROUP 64
#define NN_BN_ACT_NONE 0u
#define NN_BN_ACT_RELU 1u
#define NN_BN_ACT_SILU 2u

struct BatchNormParams {
  uint count;
  uint channels;
  uint spatial;        // elements per (batch, channel)
  uint activation;
  uint first_channel;  // the channel of the window's first element
  uint first_spatial;  // its position inside that channel's spatial run
  uint x_offset;       // elements: the window's first element inside the x binding
  uint y_offset;       // the same inside the y binding
};

ICUBE_SHADER_NAMESPACE_END

ICUBE_CHECK_SIZE(SparseGridParams, 36);
ICUBE_CHECK_SIZE(SparseHashParams, 16);
ICUBE_CHECK_SIZE(SparseConvParams, 80);
ICUBE_CHECK_LAYOUT(SparseConvParams, co_lead, 64);
ICUBE_CHECK_LAYOUT(SparseConvParams, row_begin, 48);
ICUBE_CHECK_LAYOUT(SparseConvParams, row_tiles, 28);
ICUBE_CHECK_LAYOUT(SparseConvParams, y_offset, 44);
ICUBE_CHECK_LAYOUT(SparseConvParams, w_ci_base, 60);
ICUBE_CHECK_SIZE(Conv3dParams, 80);
ICUBE_CHECK_LAYOUT(Conv3dParams, co_vec4s, 28);
ICUBE_CHECK_LAYOUT(Conv3dParams, kernel, 44);
ICUBE_CHECK_LAYOUT(Conv3dParams, x_offset, 60);
ICUBE_CHECK_LAYOUT(Conv3dParams, y_batch_stride, 72);
ICUBE_CHECK_LAYOUT(Conv3dParams, w_ci_base, 76);

ICUBE_CHECK_SIZE(Conv2dParams, 96);
ICUBE_CHECK_LAYOUT(Conv2dParams, in_h, 32);
ICUBE_CHECK_LAYOUT(Conv2dParams, pixel_tiles, 64);
ICUBE_CHECK_LAYOUT(Conv2dParams, w_ci_base, 92);
ICUBE_CHECK_SIZE(GroupNormParams, 64);
ICUBE_CHECK_LAYOUT(GroupNormParams, span_end, 52);
ICUBE_CHECK_LAYOUT(GroupNormParams, batch_offset, 44);
ICUBE_CHECK_SIZE(LayerNormParams, 16);
ICUBE_CHECK_SIZE(AttentionParams, 48);
ICUBE_CHECK_LAYOUT(AttentionParams, scale, 36);
ICUBE_CHECK_SIZE(ElementwiseParams, 32);
ICUBE_CHECK_LAYOUT(ElementwiseParams, y_offset, 24);
ICUBE_CHECK_SIZE(ResampleParams, 32);
ICUBE_CHECK_SIZE(DdimStepParams, 36);
ICUBE_CHECK_LAYOUT(DdimStepParams, sigma, 28);
ICUBE_CHECK_SIZE(LatentOverwriteParams, 32);
ICUBE_CHECK_LAYOUT(LatentOverwriteParams, mask_base, 24);
ICUBE_CHECK_SIZE(DpmSolverStepParams, 36);
ICUBE_CHECK_LAYOUT(DpmSolverStepParams, c_1, 28);
ICUBE_CHECK_LAYOUT(ResampleParams, x_offset, 20);
ICUBE_CHECK_LAYOUT(GroupNormParams, eps, 20);

ICUBE_CHECK_SIZE(InterpolateParams, 36);
ICUBE_CHECK_LAYOUT(InterpolateParams, mode, 20);
ICUBE_CHECK_LAYOUT(InterpolateParams, y_offset, 32);
ICUBE_CHECK_SIZE(BatchNormParams, 32);
ICUBE_CHECK_LAYOUT(BatchNormParams, first_channel, 16);
ICUBE_CHECK_LAYOUT(BatchNormParams, y_offset, 28);
#endif

// Push constants of the network-layer kernels the GSM's image and voxel
// branches add (shaders/nn/conv_transpose2d.comp, rms_norm.comp, gsm_pixel_gaussians.comp,
// gsm_project_features.comp, gsm_voxel_gaussians.comp, gsm_sky_colors.comp, scatter_mean.comp; host modules
// kernels/nn/<op>.cpp). Shared between GLSL
// and C++ (gpu_types.h); the sizes and offsets are checked at the end.
#ifndef ICUBE_NN_GSM_PARAMS_H
#define ICUBE_NN_GSM_PARAMS_H
#include "gpu_types.h"

// conv_transpose2d register tile: each invocation computes NN_CONVT2D_CO_TILE
// output channels at NN_CONVT2D_XRUN output columns of one row that share a
// column phase (ox + padding) mod stride, i.e. columns stride apart, whose
// inputs are then consecutive columns through the same taps.
#define NN_CONVT2D_GROUP 64
#define NN_CONVT2D_XRUN 4
#define NN_CONVT2D_CO_TILE 8

// rms_norm: one invocation per pixel loops over the channels up to three times
// (the sum of squares; again scaled by a power of two when that overflows or
// underflows; the output), so channels are limited to keep it under
// lavapipe's 65,535 loop iterations.
#define NN_RMS_GROUP 64
#define NN_RMS_MAX_CHANNELS 20000u
#define NN_RMS_FLAG_SILU 1u

// scatter_mean: one invocation per (voxel, channel) sums at most
// NN_SM_PIXEL_WINDOW list entries per dispatch (plus two binary searches of at
// most 33 steps), under lavapipe's 65,535 loop iterations.
#define NN_SM_GROUP 64
#define NN_SM_PIXEL_WINDOW 32768u
#define NN_SM_FLAG_ALL_VIEWS 1u   // the feature window holds every view: no search for the view's sub-list
#define NN_SM_FLAG_FIRST 2u       // the first dispatch of a voxel window: voxels without pixels get 0

ICUBE_SHADER_NAMESPACE_BEGIN

// conv_transpose2d: PyTorch's ConvTranspose2d in gather form on dense NCHW
// float32: y[b, o, oy, ox] = bias[o] + sum over ci and the taps (ky, kx) with
// oy + padding - ky = iy * stride and ox + padding - kx = ix * stride (iy, ix
// inside the input) of w[ci, o, ky, kx] x[b, ci, iy, ix]. Weights packed as
// [ci * kh * kw + tap][out channels padded to 8]. One dispatch covers `batch`
// batch elements, output channels [co_begin, co_begin + co_count) and
// `ci_count` input channels bound from x_offset (their packed weights from the
// vec4 w_offset); accumulate = 1 adds to y (later input-channel windows).
// Invocation t of a batch element and channel block: output row t / (stride *
// runs), column phase (t / runs) % stride, run t % runs of NN_CONVT2D_XRUN
// columns of that phase. Workgroup g: pixel tile g % pixel_tiles, then channel
// block, then batch.
struct ConvTranspose2dParams {
  uint batch;
  uint co_begin;        // multiple of NN_CONVT2D_CO_TILE
  uint co_count;
  uint ci_count;
  uint co_blocks;       // ceil(co_count / NN_CONVT2D_CO_TILE)
  uint co_vec4s;        // packed weight row length in vec4s: ceil(out_channels / 8) * 2
  uint in_h;
  uint in_w;
  uint out_h;
  uint out_w;
  uint kernel_h;
  uint kernel_w;
  uint stride;
  uint padding;
  uint runs;            // runs per (row, phase): ceil(ceil(out_w / stride) / NN_CONVT2D_XRUN)
  uint pixel_tiles;     // ceil(out_h * stride * runs / NN_CONVT2D_GROUP)
  uint has_bias;
  uint accumulate;
  uint x_offset;        // elements: input channel 0 of the window of the first batch element
  uint x_batch_stride;
  uint y_offset;        // elements: output channel co_begin of the first batch element
  uint y_batch_stride;
  uint w_offset;        // vec4s: the packed row of the window's first input channel, tap 0
  uint pad0;
};

// rms_norm: x-unet's RMSNorm over the channels of [batch, channels, plane]
// float32: y = x / max(|x_pixel|_2, eps) * scale * gamma[c] (scale = sqrt(C)),
// then SiLU with NN_RMS_FLAG_SILU. One invocation per pixel; a dispatch covers
// `batch` batch elements (batch_stride apart) and `pixels` consecutive pixels
// of each, bound from x_offset / y_offset (channel c of a pixel is plane
// elements further).
struct RmsNormParams {
  uint batch;
  uint pixels;
  uint channels;
  uint plane;         // elements per channel (H * W)
  uint batch_stride;  // elements between batch elements (channels * plane)
  uint flags;
  float eps;
  float scale;
  uint x_offset;
  uint y_offset;
  uint pad0;
  uint pad1;
};

// scatter_mean: the voxel lifter's mean. Effective pixels q = n * plane + p
// (view n, pixel p) listed per voxel in ascending q (CSR: list positions
// [offsets[v], offsets[v + 1]) of pixel_ids); y[v, c] = the sum of
// features[n, c, p] over the list in that order, divided by its length
// (0 for an empty list). A dispatch covers `voxels` voxels (their offsets bound
// from offsets_offset, y rows from y_offset), channels [channel_begin,
// channel_begin + channels) of views [view_begin, view_end) (the feature window
// from x_offset, channel c of view n at ((n - view_begin) * channels_total +
// c - channel_begin) * plane), and list positions [a + pass * pixel_window,
// + pixel_window) of each voxel's sub-list [a, b) in those views. The partial
// sum is kept in y between dispatches (same order as one loop).
struct ScatterMeanParams {
  uint voxels;
  uint channels;        // in this dispatch
  uint channels_total;  // C: the row length of y and the channel count of the features
  uint plane;           // H * W
  uint view_begin;
  uint view_end;
  uint channel_begin;
  uint pass;
  uint pixel_window;
  uint flags;
  uint x_offset;        // elements inside the feature binding (texel window)
  uint y_offset;        // elements: row 0 of the voxel window inside the y binding
  uint offsets_offset;  // elements: offsets[voxel window's first] inside the offsets binding
  uint pixel_first;     // the list position of the first bound pixel id
  uint pixels_offset;   // elements: where that pixel id sits inside the pixel-id binding
  uint pad0;
};

ICUBE_SHADER_NAMESPACE_END

ICUBE_CHECK_SIZE(ConvTranspose2dParams, 96);
ICUBE_CHECK_LAYOUT(ConvTranspose2dParams, in_h, 24);
ICUBE_CHECK_LAYOUT(ConvTranspose2dParams, runs, 56);
ICUBE_CHECK_LAYOUT(ConvTranspose2dParams, x_offset, 72);
ICUBE_CHECK_LAYOUT(ConvTranspose2dParams, w_offset, 88);
ICUBE_CHECK_SIZE(RmsNormParams, 48);
ICUBE_CHECK_LAYOUT(RmsNormParams, eps, 24);
ICUBE_CHECK_LAYOUT(RmsNormParams, y_offset, 36);
ICUBE_CHECK_SIZE(ScatterMeanParams, 64);
ICUBE_CHECK_LAYOUT(ScatterMeanParams, pass, 28);
ICUBE_CHECK_LAYOUT(ScatterMeanParams, x_offset, 40);
ICUBE_CHECK_LAYOUT(ScatterMeanParams, pixels_offset, 56);
// gsm_pixel_gaussians (the pixel branch's Gaussian decoding, one invocation per
// pixel of one view; host module kernels/nn/gsm_pixel_gaussians.{h,cpp}): a
// view's camera is NN_GSMPIX_CAMERA_FLOATS floats in the camera buffer, the
// camera-to-grid pose row-major (16) then fx, fy, cx, cy (4), then padding.
#define NN_GSMPIX_GROUP 64
#define NN_GSMPIX_CAMERA_FLOATS 24u
#define NN_GSMPIX_MAX_PARAMS 1024u             // gs_per_pixel * gs_dim: the loops stay far under lavapipe's 65,535
#define NN_GSMPIX_FLAG_INVERSE_DEPTH 1u        // interpret_output_depth "inverse_metric_depth": depth = 1 / sigmoid
#define NN_GSMPIX_FLAG_MIDGROUND 2u            // keep = fg - fg * grid_fg (with the voxel branch), else fg

ICUBE_SHADER_NAMESPACE_BEGIN

// gsm_pixel_gaussians: raw values params[s * gs_dim + k][pixel] (channel-major,
// one view's [gs_per_pixel * gs_dim, pixels] window from params_offset) ->
// per Gaussian gs_dim + 2 floats at out[out_offset + (pixel * gs_per_pixel + s)
// * (gs_dim + 2)]: mean 3 (grid frame), scale 3, rotation 4, opacity 1, colour
// gs_dim - 9; and the mask value (fg - fg * grid_fg, or fg) per pixel at
// mask[mask_offset + pixel]. fg / grid_fg: 0 / 1 floats per pixel.
struct GsmPixelGaussiansParams {
  uint pixels;          // H * W of the view
  uint width;
  uint gs_per_pixel;
  uint gs_dim;
  uint flags;           // NN_GSMPIX_FLAG_*
  uint camera;          // float offset of the view's camera in the camera binding
  float znear;
  float depth_range;    // zfar - znear
  float max_scale;
  uint params_offset;   // elements inside each binding (the view's window)
  uint fg_offset;
  uint grid_offset;
  uint out_offset;
  uint mask_offset;
  uint pad0;
  uint pad1;
};

ICUBE_SHADER_NAMESPACE_END

ICUBE_CHECK_SIZE(GsmPixelGaussiansParams, 64);
ICUBE_CHECK_LAYOUT(GsmPixelGaussiansParams, znear, 24);
ICUBE_CHECK_LAYOUT(GsmPixelGaussiansParams, params_offset, 36);
ICUBE_CHECK_LAYOUT(GsmPixelGaussiansParams, mask_offset, 52);

// The voxel branch's own kernels (gsm_project_features, gsm_voxel_gaussians).
#define NN_GSM_PROJECT_GROUP 64
#define NN_GSM_PROJECT_FLAG_MAX_FROM_ZERO 1u  // the maximum over the views starts from 0 (else -inf)
#define NN_GSM_PROJECT_FLAG_ACCUMULATE 2u     // ... from the y of the earlier views' windows
// Views one invocation loops over (lavapipe's 65,535 loop iterations; 4 taps each).
#define NN_GSM_PROJECT_MAX_VIEWS 4096u

#define NN_GSM_GAUSSIANS_GROUP 64

// gsm_sky_colors: one invocation per direction walks the hidden units three
// times (mean, variance, output), so hidden * (3 + out_channels) stays far
// under lavapipe's 65,535 loop iterations.
#define NN_GSM_SKY_GROUP 64
#define NN_GSM_SKY_MAX_OUT 4u
#define NN_GSM_SKY_MAX_HIDDEN 4096u

ICUBE_SHADER_NAMESPACE_BEGIN

// gsm_project_features: for each child voxel r of a grid (centre ijk[r] *
// voxel_size + origin) and feature channel c, the maximum over the views n of
// (seen[parent[r] * views + n] != 0 ? sample_n(c) : 0), starting from -inf
// (or 0 with NN_GSM_PROJECT_FLAG_MAX_FROM_ZERO), where sample_n is
// F.grid_sample(bilinear, zeros, align_corners=False) of the masked feature
// map features[n, c] * (mask[n] > 0) at the centre projected by view n's 3x4
// matrix (to (u w', v w', w'), u and v normalised by the image size: pixel
// x = u * width - 0.5). Doubles travel as float pairs (hi, lo = the rest):
// the matrices as proj[(n * 12 + k) * 2 + {0, 1}], voxel size and origin here;
// the float32 shader uses hi alone, the float64 one hi + lo. Features
// [views][channels][height][width], mask [views][height][width], y
// [channels][rows]. Tensors past one storage binding go in windows of views,
// channels and children, one dispatch each, one invocation per output element
// of the window; a window of later views (NN_GSM_PROJECT_FLAG_ACCUMULATE)
// takes the maximum with the y the earlier views left (the caller orders the
// two with a barrier).
struct GsmProjectParams {
  uint rows;      // children of the dispatch's window
  uint channels;  // channels of the window
  uint views;     // all views (the seen table's stride; proj holds them all)
  uint height;
  uint width;
  uint flags;
  uint view_first;  // the window's views: view_first .. + view_count
  uint view_count;
  uint channel_stride;  // all channels (the features' layout)
  uint row_stride;      // all children (the output's channel stride)
  uint features_offset;  // each window's first element inside its binding (bound from an aligned offset)
  uint mask_offset;
  uint ijk_offset;
  uint parent_offset;
  uint out_offset;
  uint pad0;
  float voxel_size_hi[4];  // x, y, z, unused
  float voxel_size_lo[4];
  float origin_hi[4];
  float origin_lo[4];
};

// gsm_voxel_gaussians: the voxel heads' raw values raw [per_voxel * gs_dim][rows]
// (channel-major) decoded into Gaussian g = first_gaussian + r * per_voxel + s
// (voxel r, sub s): mean = min corner (ijk * voxel_size + corner) + sigmoid(xyz)
// * voxel_size, scale = exp(raw) * scale_unit (clamped to max_scaling when
// > 0), rotation = quaternion / max(norm, 1e-12), opacity = sigmoid, colour =
// the remaining gs_dim - 11 raw values. Outputs row-major per Gaussian. One
// dispatch per window of `rows` voxels from r0 and `subs` subs from s0 (the
// tensors past one storage binding): one invocation per (voxel, sub) of the
// window; every binding starts at its window (the *_offset fields: the
// window's first element inside its binding, which starts at an aligned
// offset), raw's channel stride is `row_stride` (all the voxels).
struct GsmVoxelGaussiansParams {
  uint rows;        // voxels of the window
  uint per_voxel;   // Gaussians per voxel (the outputs' stride per voxel)
  uint gs_dim;
  uint subs;        // subs of the window
  uint row_stride;  // voxels of the head (raw's channel stride)
  uint raw_offset;  // raw[(s0 * gs_dim) * row_stride + r0] inside the raw binding
  uint ijk_offset;  // ijk[3 * r0]
  uint means_offset;  // per output: Gaussian first_gaussian + r0 * per_voxel + s0's first value
  uint scales_offset;
  uint rotations_offset;
  uint opacities_offset;
  uint colors_offset;
  float voxel_size_x;
  float voxel_size_y;
  float voxel_size_z;
  float scale_unit;
  float corner_x;  // origin - voxel_size / 2
  float corner_y;
  float corner_z;
  float max_scaling;  // <= 0: none
};

// gsm_sky_colors: the sky modulator MLP (InfiniCube skybox_mlp_modulator) for
// unit directions dirs [rows][3]: h = pos_w d + pos_b ([hidden]), LayerNorm
// over h without affine (eps 1e-6), m = n (1 + scale_e) + shift_e with the
// modulation [elements][2 hidden] (shift, then scale) of row g's element e =
// element_first + g / element_rows, colour = out_w m + out_b ([out_channels]).
// mlp = pos_w [hidden][3], pos_b [hidden], out_w [out_channels][hidden], out_b
// [out_channels]. One dispatch per window of rows (directions and colours past
// one storage binding), one invocation per row; first_row is the window's
// first row, the offsets its first elements inside the bindings.
struct GsmSkyColorsParams {
  uint rows;           // of the window
  uint hidden;
  uint out_channels;   // 1 to NN_GSM_SKY_MAX_OUT
  uint element_rows;   // rows per element
  uint first_row;      // the window's first row (its element)
  uint element_first;  // the element of row 0
  uint dir_offset;     // dirs[3 * first_row] inside the directions' binding
  uint out_offset;     // y[out_channels * first_row] inside the output's binding
};

ICUBE_SHADER_NAMESPACE_END

ICUBE_CHECK_SIZE(GsmProjectParams, 128);
ICUBE_CHECK_LAYOUT(GsmProjectParams, out_offset, 56);
ICUBE_CHECK_LAYOUT(GsmProjectParams, voxel_size_hi, 64);
ICUBE_CHECK_LAYOUT(GsmProjectParams, origin_lo, 112);
ICUBE_CHECK_SIZE(GsmVoxelGaussiansParams, 80);
ICUBE_CHECK_LAYOUT(GsmVoxelGaussiansParams, colors_offset, 44);
ICUBE_CHECK_LAYOUT(GsmVoxelGaussiansParams, scale_unit, 60);
ICUBE_CHECK_LAYOUT(GsmVoxelGaussiansParams, max_scaling, 76);
ICUBE_CHECK_SIZE(GsmSkyColorsParams, 32);
ICUBE_CHECK_LAYOUT(GsmSkyColorsParams, out_offset, 28);
#endif

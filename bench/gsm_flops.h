// FLOP counts of one GSM forward by stage, for icube-bench-gsm's rates and its
// estimate of a discrete GPU's time: 2 x multiply-adds of every convolution,
// linear layer and attention (softmax, norms, activations and resampling are
// left out: < 2 % of the total at the released widths), from the weights' shapes
// and where each layer runs:
//   conv encoder        every conv at the input resolution (the release's strides are 1)
//   Depth-Anything-V2   per view: patch embedding, every layer up to the last selected one (q, k, v, output,
//                       MLP; attention 4 T^2 C), the neck's projections / resamples (a transposed conv of
//                       factor f costs 2 |W| per input pixel) / 3x3 convs, the fusion units and projections,
//                       the upsampler's blocks
//   voxel branch        per batch element: lifter and pre_conv on the input voxels, each level's blocks on its
//                       hash-tree grid (gsm_hash_tree_level), decoder blocks on 8 x the next coarser level's
//                       voxels, the heads on the children of the voxels some view hits first (the pixel rays,
//                       gsm_rays.h, cast here) and on the other voxels; a sparse 3x3x3 conv counts all 27 taps
//                       (the dense equivalent; an upper bound of the work on a surface grid)
//   pixel branch        x-unet by parameter name: level l of a layer at (H / 2^l) x (W / 2^l) (init, final
//                       and consolidator convs at full size; downs.s at s, its space-to-depth conv at s + 1;
//                       mid at the coarsest; ups.u at stages - 1 - u; transposed convs per input pixel), mid
//                       attention over the coarsest map, linear_out per pixel
//   sky                 patch embedding, the transformer over the sky patches (> 75 % sky pixels) plus the
//                       query, the modulator per input pixel and panorama pixel
// Used by bench/bench_gsm.cpp only.
#pragma once

#include "nn/gsm/gsm_reference.h"

namespace icube::bench {

struct GsmFlops {
  double conv_encoder = 0, dav2 = 0;  // all views
  double voxel_branch = 0, pixel_branch = 0;
  double sky_token = 0, sky_colours = 0;
  double dav2_per_view = 0;
  double total() const { return conv_encoder + dav2 + voxel_branch + pixel_branch + sky_token + sky_colours; }
};

// Casts the pixel rays of every batch element (seconds on the host at the released size).
GsmFlops gsm_flops(const nn::GsmConfig& c, const nn::GsmWeights& w, const nn::GsmInputs& in);

// Depth-Anything-V2's FLOPs for one view (the term of gsm_flops).
double dav2_flops_per_view(const nn::Dav2Config& c, const nn::GsmWeights& w);

}  // namespace icube::bench

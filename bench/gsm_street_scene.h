// The synthetic scene of icube-bench-gsm: a straight street in the GSM's input
// convention (nn/gsm/gsm_inputs.h: grid x forward, y left, z up; 0.2 m voxels,
// origin 0.1 m), seen by front cameras driving along it:
//   voxels   an 80 m road slab 12 m wide, raised sidewalks, building facades of
//            8-16 m on both sides with alleys every 20 m, six parked cars (shells);
//            about 86,000 voxels, rows sorted lexicographically
//   cameras  OpenCV axes looking along +x from 2 m height in the right lane,
//            key frames 5 m apart; the Waymo FRONT camera's focal length scaled
//            to the image (2055 px at 1920 x 1280)
//   images   each pixel's ray marched through the voxels (gsm_rays.h): the first
//            voxel's surface colour (asphalt with lane dashes, pavement, facades
//            with windows, cars) with per-voxel noise; rays that miss the grid
//            meet the road, facades and a backdrop beyond it (mid-ground) or the
//            sky (a vertical gradient)
//   masks    ch0 0 on the sky, 1 elsewhere; ch1, ch2 1 (nothing dynamic, no hood);
//            ch3 0 (recomputed by the model)
//   depth-patch draw  each 16 x 16 patch kept with probability 1/2 (seeded)
// Deterministic for a seed. Used by bench/bench_gsm.cpp only.
#pragma once

#include "nn/gsm/gsm_inputs.h"

#include <cstdint>

namespace icube::bench {

// One batch element of `views` views of height x width pixels (multiples of 16).
nn::GsmInputs street_scene(int64_t views, int64_t height, int64_t width, uint32_t seed);

// The first `views` views of a batch-1 scene (the same voxels).
nn::GsmInputs first_views(const nn::GsmInputs& in, int64_t views);

}  // namespace icube::bench

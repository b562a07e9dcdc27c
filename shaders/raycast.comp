#version 460
#extension GL_GOOGLE_include_directive : require
// raycast: the voxel ray caster (float; see common/raycast_kernel.glsl for what it
// computes and its conventions). Host module: engine/render/raycast_gpu.{h,cpp}.
#include "common/raycast_kernel.glsl"

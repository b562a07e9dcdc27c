#version 460
#extension GL_GOOGLE_include_directive : require
// raycast: the voxel ray caster (float; see raycast/kernel.glsl for what it
// computes and its conventions). Host module: engine/render/raycast_gpu.{h,cpp}.
// Tests: tests/render/test_raycast.cpp, tests/render/test_raycast_index.cpp.
#include "raycast/kernel.glsl"

#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_shader_explicit_arithmetic_types_float64 : require
// raycast_exact: the voxel ray caster of raycast/kernel.glsl with the
// near-threshold semantic chords of camera rays decided in double (needs
// shaderFloat64). Host module: engine/render/raycast_gpu.{h,cpp}.
// Tests: tests/render/test_raycast.cpp (the exact-pass cases).
#define RAYCAST_EXACT_F64 1
#include "raycast/kernel.glsl"

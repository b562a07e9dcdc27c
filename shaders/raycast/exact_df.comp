#version 460
#extension GL_GOOGLE_include_directive : require
// raycast_exact_df: the voxel ray caster of raycast/kernel.glsl with the
// near-threshold semantic chords of camera rays decided in double-float
// (~48-bit fp32 pairs, common/df.glsl), the exact pass of devices without
// shaderFloat64: the chord of raycast/traverse.glsl's raycast_chord_df from the
// camera of binding 7 as float pairs (shared/raycast_df_params.h), with the CPU
// reference's formulas; why its decisions are the reference's: traverse.glsl.
// Host module: engine/render/raycast_gpu.{h,cpp} (set_exact_float_only forces it
// where shaderFloat64 exists). Tests: tests/render/test_raycast_index.cpp (the
// exact-pass cases, against the CPU on the synthetic, demo and Waymo worlds),
// tests/render/test_raycast_df.cpp (the df primitives, via raycast/df_check.comp).
#define RAYCAST_EXACT_DF 1
#include "raycast/kernel.glsl"

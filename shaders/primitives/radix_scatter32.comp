#version 460
#extension GL_GOOGLE_include_directive : require
// radix_scatter32: stable scatter of one LSD radix pass over uint32 keys + uint32 values.
//
// For key i of tile t with digit d: dst = offsets[d * num_tiles + t] + (number
// of earlier keys of tile t with digit d); keys_out[dst] = keys_in[i],
// values_out[dst] = values_in[i]. Ranks inside a subgroup batch come from
// ballots (lane order = input order); running per-digit offsets live in
// shared memory, read and advanced only by each digit group's highest lane.
// Body: shaders/primitives/radix_scatter.glsl. Host module and CPU reference:
// kernels/radix_sort.{h,cpp}. Tests: tests/primitives/test_radix_sort.cpp.

#include "primitives/radix_scatter.glsl"

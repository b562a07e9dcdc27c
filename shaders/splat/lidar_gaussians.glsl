// The LiDAR caster's Gaussian records (SplatLidarGaussian, 4 vec4 each) bound as
// SPLAT_LIDAR_WINDOWS storage windows of p.window_n records (the last may hold
// fewer; unused windows are null bindings), starting at binding
// LIDAR_GAUSSIAN_BINDING. gaussian_vec4(i, k) is vec4 k of record i.
// Included by splat/lidar_bin.comp and splat/lidar_cast.comp (which declare `p`).
layout(std430, binding = LIDAR_GAUSSIAN_BINDING + 0) readonly buffer GaussiansW0 { vec4 gw0[]; };
layout(std430, binding = LIDAR_GAUSSIAN_BINDING + 1) readonly buffer GaussiansW1 { vec4 gw1[]; };
layout(std430, binding = LIDAR_GAUSSIAN_BINDING + 2) readonly buffer GaussiansW2 { vec4 gw2[]; };
layout(std430, binding = LIDAR_GAUSSIAN_BINDING + 3) readonly buffer GaussiansW3 { vec4 gw3[]; };

vec4 gaussian_vec4(uint i, uint k) {
  const uint w = i / p.window_n;
  const uint j = 4u * (i - w * p.window_n) + k;
  if (w == 0u) return gw0[j];
  if (w == 1u) return gw1[j];
  if (w == 2u) return gw2[j];
  return gw3[j];
}

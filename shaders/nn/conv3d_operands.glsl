// The implicit-GEMM operands of conv3d for the tiled paths (conv3d_tiled.glsl,
// conv3d_coopmat.glsl): A[m][k] = x[b, ci, voxel m + tap offset] (zero outside
// the grid), k = ci * taps + tap in the dispatch's input-channel window, and
// B[k][n] = the packed weight of row k and output channel n. Expects NN_K, the
// push constants `p` and the texel buffer `x_tex` declared before inclusion.

const uint NN_TAPS = uint(NN_K * NN_K * NN_K);

// One output voxel's grid coordinates (m past the grid: valid = false).
struct ConvVoxel {
  int x, y, z;
  bool valid;
};

ConvVoxel conv_voxel(uint m) {
  ConvVoxel v;
  const uint S = p.size_x * p.size_y * p.size_z;
  v.valid = m < S;
  const uint mm = v.valid ? m : 0u;
  v.z = int(mm % p.size_z);
  v.y = int((mm / p.size_z) % p.size_y);
  v.x = int(mm / (p.size_z * p.size_y));
  return v;
}

// A[m][k] for the voxel of row m; x_base = the batch element's first element in the x binding.
float conv_a(ConvVoxel v, uint k, uint k_count, uint x_base) {
  if (!v.valid || k >= k_count) return 0.0;
  const uint ci = k / NN_TAPS, tap = k - ci * NN_TAPS;
  const int H = NN_K / 2;
  const int qx = v.x + int(tap / uint(NN_K * NN_K)) - H;
  const int qy = v.y + int((tap / uint(NN_K)) % uint(NN_K)) - H;
  const int qz = v.z + int(tap % uint(NN_K)) - H;
  if (qx < 0 || qy < 0 || qz < 0 || qx >= int(p.size_x) || qy >= int(p.size_y) || qz >= int(p.size_z)) return 0.0;
  const uint S = p.size_x * p.size_y * p.size_z;
  return texelFetch(x_tex, int(x_base + ci * S + (uint(qx) * p.size_y + uint(qy)) * p.size_z + uint(qz))).x;
}

// The packed weight row of GEMM row k (relative to the bound weight window).
uint conv_weight_row(uint k) { return (p.ci_begin - p.w_ci_base) * NN_TAPS + k; }

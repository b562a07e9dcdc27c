// Exact tile culling of a projected Gaussian: the tiles of one row of its
// tile rect (Inria getRect, splat/project.glsl) that its α-cut ellipse
// q(d) = a'dx² + 2b'dxdy + c'dy² <= R, R = −2·log_cut (log_cut =
// ln(0.9/(255·o)), the blend record's 10 % margin), reaches. Tile t covers the
// pixel samples [16t + o, 16t + 15 + o] (o = 0 or 0.5); the test uses the
// span [16t − SPLAT_CULL_MARGIN, 16t + 16 + SPLAT_CULL_MARGIN]. For the row's
// slab dy ∈ [lo, hi] (clamped to the ellipse's y extent ±√(Ra'/D), D = a'c' −
// b'²) the chord's right end −b'dy/a' + √(a'R − D·dy²)/a' is concave in dy, so
// its maximum over the slab is at dy clamped to the rightmost point's
// −(b'/c')·√(Rc'/D) (and symmetrically the left end). Returns [x0, x1) within
// the rect row (x0 == x1: none). Non-finite intermediates keep the whole rect
// row (conservative). Mirrors engine/splat/rasterizer_cpu.cpp
// tile_row_span() operation by operation; every intermediate is `precise`
// (no fused multiply-adds), so the CPU reference gets the same tiles.
#ifndef ICUBE_SPLAT_TILES_GLSL
#define ICUBE_SPLAT_TILES_GLSL

uvec2 splat_tile_row(float mx, float my, float a, float b, float c, float log_cut, uvec4 rect, uint ty) {
  precise float R = -2.0 * log_cut;
  precise float D = a * c - b * b;
  precise float ex = sqrt(R * c / D);
  precise float ey = sqrt(R * a / D);
  precise float lo = max(float(ty * 16u) - SPLAT_CULL_MARGIN - my, -ey);
  precise float hi = min(float(ty * 16u + 16u) + SPLAT_CULL_MARGIN - my, ey);
  precise float dyr = -(b / c) * ex;
  precise float yr = min(max(dyr, lo), hi);
  precise float yl = min(max(-dyr, lo), hi);
  precise float sr = sqrt(max(0.0, a * R - D * (yr * yr)));
  precise float sl = sqrt(max(0.0, a * R - D * (yl * yl)));
  precise float xr = mx + (sr - b * yr) / a;
  precise float xl = mx + (-sl - b * yl) / a;
  precise float fx0 = floor((xl - SPLAT_CULL_MARGIN) / 16.0);
  precise float fx1 = floor((xr + SPLAT_CULL_MARGIN) / 16.0) + 1.0;
  const bool ok = !isnan(R + D + ex + ey + xr + xl) && !isinf(R + D + ex + ey + xr + xl) && D > 0.0 && a > 0.0 &&
                  c > 0.0;
  if (!ok) return rect.xz;
  if (lo > hi) return uvec2(rect.x);
  const float x0 = min(max(fx0, float(rect.x)), float(rect.z));
  const float x1 = min(max(fx1, x0), float(rect.z));
  return uvec2(x0, x1);
}

// SplatBinRecord (shared/splat_params.h): the inputs of splat_tile_row for one Gaussian in
// depth order, packed by splat_sorted_counts and read back (as two R32G32B32A32_UINT texels)
// by the binning kernels. Tile coordinates fit 16 bits (checked on the host).
SplatBinRecord splat_pack_bin_record(vec4 g0, vec4 g1, uvec4 rect) {
  SplatBinRecord b;
  b.mean_x = g0.x;
  b.mean_y = g0.y;
  b.conic_x = g0.z;
  b.conic_y = g0.w;
  b.conic_z = g1.x;
  b.log_cut = g1.y;
  b.rect_x = rect.x | (rect.z << 16);
  b.rect_y = rect.y | (rect.w << 16);
  return b;
}

// g0 = (mean, conic a', b'), g1 = (conic c', log_cut, 0, 0), rect, of depth position j.
void splat_read_bin_record(usamplerBuffer records, uint j, out vec4 g0, out vec4 g1, out uvec4 rect) {
  g0 = uintBitsToFloat(texelFetch(records, int(2u * j)));
  const uvec4 t1 = texelFetch(records, int(2u * j + 1u));
  g1 = vec4(uintBitsToFloat(t1.xy), 0.0, 0.0);
  rect = uvec4(t1.z & 0xFFFFu, t1.w & 0xFFFFu, t1.z >> 16, t1.w >> 16);
}

#endif

// Greedy meshing: collect exposed faces, group them by plane, merge rectangles.
#include "world/greedy_mesh.h"

#include <algorithm>
#include <tuple>
#include <unordered_map>

namespace icube::world {

namespace {

struct Face {
  uint8_t axis;
  uint8_t positive;
  int32_t plane, u, v;
  uint8_t cls;
};

uint64_t pack_uv(int32_t u, int32_t v) {
  return (static_cast<uint64_t>(static_cast<uint32_t>(u)) << 32) | static_cast<uint32_t>(v);
}

}  // namespace

std::array<glm::ivec3, 4> quad_corners(const MeshQuad& q) {
  const int a = q.axis, ua = (a + 1) % 3, va = (a + 2) % 3;
  auto corner = [&](int32_t u, int32_t v) {
    glm::ivec3 c;
    c[a] = q.plane;
    c[ua] = u;
    c[va] = v;
    return c;
  };
  const glm::ivec3 c00 = corner(q.u0, q.v0), c10 = corner(q.u0 + q.du, q.v0), c11 = corner(q.u0 + q.du, q.v0 + q.dv),
                   c01 = corner(q.u0, q.v0 + q.dv);
  // e_u x e_v = e_axis, so (00, 10, 11, 01) is counter-clockwise seen from +axis.
  if (q.positive) return {c00, c10, c11, c01};
  return {c00, c01, c11, c10};
}

std::vector<MeshQuad> greedy_mesh(const VoxelGrid& grid) {
  std::vector<Face> faces;
  grid.for_each_voxel([&](const glm::ivec3& ijk, const Voxel& vox) {
    for (uint8_t a = 0; a < 3; ++a)
      for (uint8_t pos = 0; pos < 2; ++pos) {
        glm::ivec3 n = ijk;
        n[a] += pos ? 1 : -1;
        if (grid.contains(n)) continue;
        const int ua = (a + 1) % 3, va = (a + 2) % 3;
        faces.push_back({a, pos, ijk[a] + (pos ? 1 : 0), ijk[ua], ijk[va], vox.class_id});
      }
  });
  auto key = [](const Face& f) { return std::tie(f.axis, f.positive, f.plane, f.v, f.u); };
  std::sort(faces.begin(), faces.end(), [&](const Face& x, const Face& y) { return key(x) < key(y); });

  std::vector<MeshQuad> quads;
  std::vector<char> used(faces.size(), 0);
  std::unordered_map<uint64_t, size_t> at;
  for (size_t g0 = 0; g0 < faces.size();) {
    size_t g1 = g0;
    while (g1 < faces.size() && faces[g1].axis == faces[g0].axis && faces[g1].positive == faces[g0].positive &&
           faces[g1].plane == faces[g0].plane)
      ++g1;
    at.clear();
    for (size_t i = g0; i < g1; ++i) at.emplace(pack_uv(faces[i].u, faces[i].v), i);
    // A free face at (u, v) of class c, or SIZE_MAX.
    auto free_at = [&](int32_t u, int32_t v, uint8_t c) -> size_t {
      auto it = at.find(pack_uv(u, v));
      if (it == at.end() || used[it->second] || faces[it->second].cls != c) return SIZE_MAX;
      return it->second;
    };
    for (size_t i = g0; i < g1; ++i) {
      if (used[i]) continue;
      const Face& f = faces[i];
      int32_t du = 1, dv = 1;
      used[i] = 1;
      for (size_t k; (k = free_at(f.u + du, f.v, f.cls)) != SIZE_MAX; ++du) used[k] = 1;
      for (;;) {  // grow along v while the whole next row is free and of the same class
        bool ok = true;
        for (int32_t t = 0; t < du && ok; ++t) ok = free_at(f.u + t, f.v + dv, f.cls) != SIZE_MAX;
        if (!ok) break;
        for (int32_t t = 0; t < du; ++t) used[free_at(f.u + t, f.v + dv, f.cls)] = 1;
        ++dv;
      }
      quads.push_back({f.cls, f.axis, f.positive != 0, f.plane, f.u, f.v, du, dv});
    }
    g0 = g1;
  }
  return quads;
}

}  // namespace icube::world

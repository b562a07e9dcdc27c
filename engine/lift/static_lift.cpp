// Stage 3 voxel branch without a network; see static_lift.h.
#include "lift/static_lift.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <tuple>

namespace icube::lift {

namespace {

constexpr int kFaceNeighbour[6][3] = {{-1, 0, 0}, {1, 0, 0}, {0, -1, 0}, {0, 1, 0}, {0, 0, -1}, {0, 0, 1}};

void add_gaussian(splat::GaussianCloud& c, const glm::dvec3& p, const glm::vec3& sigma, float opacity,
                  const glm::vec3& rgb) {
  const float dc[3] = {static_cast<float>((double(rgb.r) - 0.5) / splat::kShC0),
                       static_cast<float>((double(rgb.g) - 0.5) / splat::kShC0),
                       static_cast<float>((double(rgb.b) - 0.5) / splat::kShC0)};
  c.add(p, sigma, glm::vec4(1.0f, 0.0f, 0.0f, 0.0f), opacity, dc);
}

}  // namespace

bool FaceKey::operator<(const FaceKey& o) const {
  return std::tie(ijk.z, ijk.y, ijk.x, slot) < std::tie(o.ijk.z, o.ijk.y, o.ijk.x, o.slot);
}

size_t FaceKeyHash::operator()(const FaceKey& k) const {
  uint64_t h = static_cast<uint32_t>(k.ijk.x) * 0x9E3779B97F4A7C15ull;
  h ^= static_cast<uint32_t>(k.ijk.y) * 0xC2B2AE3D27D4EB4Full + (h << 6) + (h >> 2);
  h ^= static_cast<uint32_t>(k.ijk.z) * 0x165667B19E3779F9ull + (h << 6) + (h >> 2);
  h ^= static_cast<uint64_t>(k.slot) * 0x27D4EB2F165667C5ull;
  return static_cast<size_t>(h ^ (h >> 29));
}

int face_slot(int normal) {
  if (normal == 0 || normal < -3 || normal > 3) throw std::invalid_argument("face_slot: normal must be ±1..3");
  return 2 * (std::abs(normal) - 1) + (normal > 0 ? 1 : 0);
}

glm::ivec3 face_axes(int slot) {
  const int n = slot / 2;
  return glm::ivec3((n + 1) % 3, (n + 2) % 3, n);
}

void StaticLiftAccumulator::add(const ColorSample& s) {
  const int slot = face_slot(s.normal);
  const glm::ivec3 ax = face_axes(slot);
  const glm::dvec3 local = (s.point - origin_) / voxel_size_ - glm::dvec3(s.ijk);  // [0, 1]³ inside the voxel
  auto quarter = [](double x) { return std::clamp(static_cast<int>(std::floor(x * kFaceGrid)), 0, kFaceGrid - 1); };
  CellAccum& c = faces_[FaceKey{s.ijk, slot}][size_t(quarter(local[ax.y]) * kFaceGrid + quarter(local[ax.x]))];
  c.sum_r += s.r;
  c.sum_g += s.g;
  c.sum_b += s.b;
  ++c.count;
  ++samples_;
}

size_t StaticLiftAccumulator::add_frame(const render::Camera& cam, render::PixelConvention pixels,
                                        const std::vector<uint8_t>& rgb, const std::vector<uint8_t>& sky,
                                        const std::vector<uint16_t>& instance,
                                        const std::vector<shader::RaycastHit>& hits) {
  const size_t W = cam.K.width, H = cam.K.height, n = W * H;
  if (rgb.size() != 3 * n || sky.size() != n || instance.size() != n || hits.size() != n)
    throw std::invalid_argument("StaticLiftAccumulator::add_frame: image sizes disagree with the camera");
  const size_t before = samples_;
  for (size_t v = 0; v < H; ++v)
    for (size_t u = 0; u < W; ++u) {
      const size_t i = v * W + u;
      const shader::RaycastHit& h = hits[i];
      if (sky[i] != 0 || instance[i] >= kDynamicInstanceMin || (h.flags & RAYCAST_FLAG_SEM) == 0u ||
          h.normal == RAYCAST_NORMAL_NONE || h.sem_instance >= kDynamicInstanceMin)
        continue;
      const render::Ray ray = render::camera_ray(cam, uint32_t(u), uint32_t(v), pixels);
      ColorSample s;
      s.ijk = glm::ivec3(h.ijk_x, h.ijk_y, h.ijk_z);
      s.normal = h.normal;
      s.point = ray.origin + double(h.t_sem) * ray.dir;
      s.r = rgb[3 * i], s.g = rgb[3 * i + 1], s.b = rgb[3 * i + 2];
      add(s);
    }
  return samples_ - before;
}

std::vector<std::pair<FaceKey, FaceCells>> StaticLiftAccumulator::sorted_faces() const {
  std::vector<std::pair<FaceKey, FaceCells>> out(faces_.begin(), faces_.end());
  std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  return out;
}

splat::GaussianCloud emit_static_gaussians(const world::VoxelGrid& grid, const StaticLiftAccumulator& acc,
                                          const LiftOptions& o, LiftStats* stats) {
  if (o.per_cell != 1 && o.per_cell != 4) throw std::invalid_argument("per_cell must be 1 or 4");
  LiftStats st;
  splat::GaussianCloud cloud;
  const double vs = grid.voxel_size(), cell = 0.5 * vs;
  const glm::dvec3 origin = grid.origin();
  const auto faces = acc.sorted_faces();

  // Mean colour per class over all seen cells (for hidden voxels).
  std::array<glm::dvec3, world::kNumSemanticClasses> class_sum{};
  std::array<uint64_t, world::kNumSemanticClasses> class_n{};
  std::vector<glm::ivec3> seen_voxels;
  seen_voxels.reserve(faces.size());
  for (const auto& [key, cells] : faces) {
    ++st.seen_faces;
    if (seen_voxels.empty() || seen_voxels.back() != key.ijk) seen_voxels.push_back(key.ijk);
    const world::Voxel vox = grid.get(key.ijk);
    const glm::ivec3 ax = face_axes(key.slot);
    const bool positive = key.slot % 2 == 1;
    // The face plane along the normal axis.
    glm::dvec3 base = origin + glm::dvec3(key.ijk) * vs;
    base[ax.z] += positive ? vs : 0.0;
    glm::dvec3 mean{0.0};
    uint64_t face_n = 0;
    for (int k = 0; k < 4; ++k) {
      const int cu = k % 2, cv = k / 2;
      CellAccum a;
      std::array<const CellAccum*, 4> q{};
      for (int qv = 0; qv < 2; ++qv)
        for (int qu = 0; qu < 2; ++qu) {
          const CellAccum& x = cells[size_t((2 * cv + qv) * kFaceGrid + 2 * cu + qu)];
          q[size_t(qv * 2 + qu)] = &x;
          a.sum_r += x.sum_r, a.sum_g += x.sum_g, a.sum_b += x.sum_b, a.count += x.count;
        }
      if (a.count == 0) continue;
      ++st.seen_cells;
      auto mean_rgb = [](const CellAccum& c) {
        return glm::dvec3(double(c.sum_r), double(c.sum_g), double(c.sum_b)) / (255.0 * double(c.count));
      };
      const glm::dvec3 rgb = mean_rgb(a);
      if (vox.class_id < world::kNumSemanticClasses) class_sum[vox.class_id] += rgb, ++class_n[vox.class_id];
      mean += rgb * double(a.count);
      face_n += a.count;
      if (o.face_gaussians) continue;
      glm::vec3 sigma(kNormalSigma);
      const float s_face = static_cast<float>(double(o.cell_sigma) * cell / std::sqrt(double(o.per_cell)));
      sigma[ax.x] = s_face;
      sigma[ax.y] = s_face;
      const int sub = o.per_cell == 4 ? 2 : 1;
      for (int qv = 0; qv < sub; ++qv)
        for (int qu = 0; qu < sub; ++qu) {
          glm::dvec3 p = base;
          p[ax.x] += (double(cu) + (double(qu) + 0.5) / double(sub)) * cell;
          p[ax.y] += (double(cv) + (double(qv) + 0.5) / double(sub)) * cell;
          const CellAccum& qa = *q[size_t(qv * 2 + qu)];
          add_gaussian(cloud, p, sigma, kSurfaceOpacity, glm::vec3(sub == 2 && qa.count > 0 ? mean_rgb(qa) : rgb));
          ++st.surface_gaussians;
        }
    }
    if (o.face_gaussians && face_n > 0) {
      glm::dvec3 p = base;
      p[ax.x] += 0.5 * vs;
      p[ax.y] += 0.5 * vs;
      glm::vec3 sigma(kNormalSigma);
      sigma[ax.x] = sigma[ax.y] = static_cast<float>(double(o.cell_sigma) * vs);
      add_gaussian(cloud, p, sigma, kSurfaceOpacity, glm::vec3(mean / double(face_n)));
      ++st.surface_gaussians;
    }
  }

  if (o.hidden) {
    std::sort(seen_voxels.begin(), seen_voxels.end(), [](const glm::ivec3& a, const glm::ivec3& b) {
      return std::tie(a.z, a.y, a.x) < std::tie(b.z, b.y, b.x);
    });
    std::vector<std::pair<glm::ivec3, uint8_t>> hidden;
    const double r2 = o.hidden_radius * o.hidden_radius;
    grid.for_each_voxel([&](const glm::ivec3& ijk, const world::Voxel& v) {
      bool exposed = false;
      for (const auto& d : kFaceNeighbour)
        if (!grid.contains(ijk + glm::ivec3(d[0], d[1], d[2]))) {
          exposed = true;
          break;
        }
      if (!exposed) return;
      if (!o.cameras.empty()) {
        const glm::dvec3 c = grid.ijk_to_world(ijk);
        bool near = false;
        for (const glm::dvec3& cam : o.cameras)
          if (glm::dot(c - cam, c - cam) <= r2) {
            near = true;
            break;
          }
        if (!near) return;
      }
      if (std::binary_search(seen_voxels.begin(), seen_voxels.end(), ijk, [](const glm::ivec3& a, const glm::ivec3& b) {
            return std::tie(a.z, a.y, a.x) < std::tie(b.z, b.y, b.x);
          }))
        return;
      hidden.emplace_back(ijk, v.class_id);
    });
    std::sort(hidden.begin(), hidden.end(), [](const auto& a, const auto& b) {
      return std::tie(a.first.z, a.first.y, a.first.x) < std::tie(b.first.z, b.first.y, b.first.x);
    });
    const glm::vec3 sigma(static_cast<float>(0.4 * vs));
    for (const auto& [ijk, cls] : hidden) {
      const glm::vec3 rgb = cls < class_n.size() && class_n[cls] > 0 ? glm::vec3(class_sum[cls] / double(class_n[cls]))
                                                                     : glm::vec3(0.5f);
      add_gaussian(cloud, grid.ijk_to_world(ijk), sigma, kHiddenOpacity, rgb);
      ++st.hidden_voxels;
      ++st.hidden_gaussians;
    }
  }
  if (stats) *stats = st;
  return cloud;
}

}  // namespace icube::lift

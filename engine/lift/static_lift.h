// Stage 3, voxel branch without a network: the static world's Gaussians lifted
// from appearance frames and the voxel world (issue 21; conventions §14).
//
// Per frame, each pixel's first-hit voxel and entry time come from the ray
// caster (the GPU's cast_camera, the buffers' rule). A pixel is a colour
// sample of that voxel's entry face when it is not sky (sky mask), not a
// dynamic object (instance >= kDynamicInstanceMin in the frame or in the hit
// voxel: the official release forgets this mask and bleeds car colours onto
// the road) and has a semantic hit. The
// hit point x = c + t·d lies on the voxel's entry face (normal ±axis); the
// face is split into 2 x 2 cells of 0.1 m (the official 0.1 m sub-voxels, seen
// from that face), each of 2 x 2 quarters of 0.05 m, and every sample adds its
// 8-bit RGB to its quarter: integer sums, so the result does not depend on the
// order of frames or threads.
//
// Gaussians (GaussianCloud: activated scale σ, opacity, wxyz rotation, SH0):
// - a seen cell: `per_cell` Gaussians (1, or 4 on a 2 x 2 pattern), flat
//   surfels in the face plane: centre = the cell's centre (per_cell 1) or its
//   quarters' centres (per_cell 4), σ = cell_sigma · cell size / √per_cell
//   along the face and kNormalSigma across it, rotation identity (faces are
//   axis-aligned), opacity kSurfaceOpacity, colour the mean RGB / 255 of the
//   cell (per_cell 1) or of the quarter (per_cell 4; a quarter without
//   samples takes its cell's), as f_dc = (rgb − 0.5) / C0 (the official
//   export's SH0, raw colours);
// - `face_gaussians` 1 folds the four cells of a face into one Gaussian
//   (σ doubled), for far chunks and budgets;
// - a hidden surface voxel (occupied, at least one empty 6-neighbour, no face
//   seen in any frame, within hidden_radius of a camera of the clip): one
//   isotropic Gaussian at its centre (σ = 0.4 voxel,
//   opacity kHiddenOpacity), coloured by the mean colour its class has over
//   all seen cells (grey 0.5 when the class was never seen).
// Interior voxels (all 6 neighbours occupied) are never visible and get none.
// Output order: seen voxels by ascending packed ijk, faces −x +x −y +y −z +z,
// cells row-major in the face's (u, v) axes; then hidden voxels by ijk.
// CPU reference and the engine path at once (the per-pixel work is the ray
// cast, already on the GPU; the accumulation is one pass over the samples).
// Tests: tests/lift/test_static_lift.cpp.
#pragma once

#include "render/camera.h"
#include "shared/raycast_params.h"
#include "splat/gaussians.h"
#include "world/voxel_grid.h"

#include <glm/glm.hpp>

#include <array>
#include <cstdint>
#include <unordered_map>
#include <utility>
#include <vector>

namespace icube::lift {

inline constexpr uint16_t kDynamicInstanceMin = 10000;  // instance ids of dynamic objects (conventions §6)
inline constexpr float kCellSigma = 0.4f;               // surfel σ along the face, in cell sizes (per_cell 1)
inline constexpr float kNormalSigma = 0.004f;           // metres across the face
inline constexpr float kSurfaceOpacity = 0.97f;
inline constexpr float kHiddenOpacity = 0.9f;

struct LiftOptions {
  int per_cell = 1;             // Gaussians per 0.1 m face cell: 1 or 4 (the official density is 4 per sub-voxel)
  float cell_sigma = kCellSigma;  // surfel σ along the face in cell sizes (per_cell 1; halved for 4)
  bool face_gaussians = false;  // one Gaussian per seen face instead of per cell
  bool hidden = true;           // one Gaussian per hidden surface voxel...
  // ...within hidden_radius metres of one of `cameras` (all hidden surface voxels when empty): the
  // rest of a town's surfaces are far from every view and would only cost sorting time.
  double hidden_radius = 40.0;
  std::vector<glm::dvec3> cameras;
};

// One pixel sample: the voxel, its entry face and the hit point.
struct ColorSample {
  glm::ivec3 ijk{0};
  int normal = 0;          // entry face, ±(axis + 1) as RaycastHit::normal
  glm::dvec3 point{0.0};   // world metres, on (or within rounding of) that face
  uint8_t r = 0, g = 0, b = 0;
};

// Integer sums (255 · 2^24 samples fit).
struct CellAccum {
  uint32_t sum_r = 0, sum_g = 0, sum_b = 0, count = 0;
};

struct FaceKey {
  glm::ivec3 ijk{0};
  int slot = 0;  // 0..5: −x +x −y +y −z +z
  bool operator==(const FaceKey& o) const { return ijk == o.ijk && slot == o.slot; }
  bool operator<(const FaceKey& o) const;  // z, y, x, slot: the output order
};
struct FaceKeyHash {
  size_t operator()(const FaceKey& k) const;
};
// 4 x 4 quarter cells of 0.05 m, row-major in the face's (u, v) axes: cell (cu, cv) of the
// 2 x 2 is quarters (2cu + qu, 2cv + qv).
inline constexpr int kFaceGrid = 4;
using FaceCells = std::array<CellAccum, kFaceGrid * kFaceGrid>;

// The samples of all frames, per voxel face and cell.
class StaticLiftAccumulator {
 public:
  explicit StaticLiftAccumulator(const world::VoxelGrid& grid) : origin_(grid.origin()), voxel_size_(grid.voxel_size()) {}
  void add(const ColorSample& s);
  // The samples of one frame: `rgb` W·H·3, `sky` W·H (nonzero = sky), `instance` W·H, and the ray
  // caster's hits of `cam`'s rays with pixel convention `pixels`. Returns the samples taken.
  size_t add_frame(const render::Camera& cam, render::PixelConvention pixels, const std::vector<uint8_t>& rgb,
                   const std::vector<uint8_t>& sky, const std::vector<uint16_t>& instance,
                   const std::vector<shader::RaycastHit>& hits);
  size_t samples() const { return samples_; }
  size_t faces() const { return faces_.size(); }
  // The seen faces in output order.
  std::vector<std::pair<FaceKey, FaceCells>> sorted_faces() const;

 private:
  glm::dvec3 origin_;
  double voxel_size_;
  size_t samples_ = 0;
  std::unordered_map<FaceKey, FaceCells, FaceKeyHash> faces_;
};

struct LiftStats {
  size_t seen_faces = 0, seen_cells = 0, hidden_voxels = 0, surface_gaussians = 0, hidden_gaussians = 0;
};

// Face slot 0..5 of a RaycastHit normal ±(axis + 1): 2·axis + (normal > 0).
int face_slot(int normal);
// The face's in-plane axes (u, v) and normal axis for slot s.
glm::ivec3 face_axes(int slot);

// The Gaussians of `grid` from the accumulated samples (see the header comment).
splat::GaussianCloud emit_static_gaussians(const world::VoxelGrid& grid, const StaticLiftAccumulator& acc,
                                          const LiftOptions& o, LiftStats* stats = nullptr);

}  // namespace icube::lift

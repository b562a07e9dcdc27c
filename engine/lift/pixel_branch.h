// Stage 3, pixel branch without a network (issue 21; conventions §14): two
// Gaussians per *mid-ground* pixel of the last key frames — a pixel the
// frame's sky mask calls not sky, the ray caster finds no voxel for, and that
// is not a dynamic object — the content a video model draws beyond the voxel
// world (hills, far buildings). With the sky mask taken from the guidance
// buffers there are no such pixels; they come from sky masks segmented from
// the frames themselves (`icube frames import --sky-masks`).
//
// Depth. The official branch predicts it (z-buffer prior + Depth-Anything);
// without a network the depth is a documented fallback, as camera-z depth z:
//  - ground: a ray that descends (world d.z < 0) meets the road plane
//    z_world = ground_z, the median top of the road and lane-marker voxels the
//    frame's rays hit (no such hit: no ground plane, the backdrop below);
//  - backdrop: any other ray ends where it leaves the world's occupied xy
//    bounds (the content lies beyond the voxel world; a camera outside those
//    bounds gives z_far);
// then z is clamped to [z_near 0.5, z_far 300] m (the official range) and the
// point is o + (z / d_cam.z)·d with d the pixel's ray (camera.h).
//
// Gaussians (GaussianCloud: σ, opacity, wxyz, SH0): two per pixel at ±¼ pixel
// along the camera's x axis at the same z, in the camera's axes (rotation =
// the camera's c2w rotation), σ = (0.3, 0.45, 0.05) · f with f = z / fx the
// pixel's footprint in metres — the official σ clamp of 0.1 m would leave far
// pixels as separated dots: a learned branch can spread them, ours must cover
// the pixel — opacity kSurfaceOpacity, colour the pixel's RGB as SH0
// ((rgb − 0.5) / C0, raw colours as the official export). Output order: frame
// by frame, pixels row-major, the −¼ Gaussian first.
// Tests: tests/lift/test_pixel_branch.cpp.
#pragma once

#include "render/camera.h"
#include "shared/raycast_params.h"
#include "splat/gaussians.h"
#include "world/voxel_grid.h"

#include <cstdint>
#include <optional>
#include <vector>

namespace icube::lift {

inline constexpr double kPixelZNear = 0.5;   // metres (conventions §14)
inline constexpr double kPixelZFar = 300.0;  // metres
inline constexpr glm::vec3 kPixelSigma{0.3f, 0.45f, 0.05f};  // σ in pixel footprints along camera x, y, z

struct PixelBranchStats {
  size_t pixels = 0;    // mid-ground pixels lifted
  size_t ground = 0;    // of them on the road plane
  size_t backdrop = 0;  // of them at the world's xy bounds (or z_far outside them)
  size_t clamped = 0;   // of them clamped to [z_near, z_far]
  size_t gaussians = 0;
  PixelBranchStats& operator+=(const PixelBranchStats& o) {
    pixels += o.pixels, ground += o.ground, backdrop += o.backdrop, clamped += o.clamped, gaussians += o.gaussians;
    return *this;
  }
};

// The road plane's height of one frame: the median top (world z) of the road / lane-marker voxels
// the frame's semantic hits name; nullopt when there are none.
std::optional<double> frame_ground_z(const world::VoxelGrid& grid, const std::vector<shader::RaycastHit>& hits);

// Whether pixel i of a frame is mid-ground: not sky, no semantic voxel hit, not a dynamic object.
bool is_midground(uint8_t sky, uint16_t instance, const shader::RaycastHit& hit);

// Appends the Gaussians of one frame's mid-ground pixels to `out` (sh_degree 0). `rgb` W·H·3,
// `sky` W·H (nonzero = sky), `instance` W·H, `hits` the ray caster's hits of `cam`'s rays with
// pixel convention `pixels` on the world the frame shows (`grid`: its bounds and road voxels).
PixelBranchStats lift_midground_pixels(const world::VoxelGrid& grid, const render::Camera& cam,
                                       render::PixelConvention pixels, const std::vector<uint8_t>& rgb,
                                       const std::vector<uint8_t>& sky, const std::vector<uint16_t>& instance,
                                       const std::vector<shader::RaycastHit>& hits, splat::GaussianCloud& out);

}  // namespace icube::lift

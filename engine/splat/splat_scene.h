// Gaussian scenes with dynamic objects: a static Gaussian set in the world
// frame plus per-object sets stored in their object frames, placed per frame by
// the objects' track poses (InfiniCube Stage 3's decoded_gs_static +
// decoded_gs_object, conventions §11, with covariances and SH rotated too:
// InfiniCube's playback moves only the means and leaves rotations
// world-oriented, which is wrong for a turning car).
//
// Object frame: the project's box frame (engine/scene/frames.h box_to_world):
// FLU, x forward along the box length, y left, z up, origin at the box centre;
// object_to_world maps object coordinates to world coordinates (metres, z up).
//
// Scene file (JSON, UTF-8), documented in docs/splat-scene.md:
//
//   {
//     "format": "icube-splat-scene",
//     "version": 1,
//     "static": "static.ply",            // optional: .ply or .splat, world frame
//     "frames": 50,                      // optional: frame count (default: 1 + last listed frame)
//     "objects": [                       // optional
//       { "id": 10000,                   // integer, unique
//         "gaussians": "car.ply",        // .ply or .splat, object frame
//         "track": [                     // one entry per frame the object is present in
//           { "frame": 0, "object_to_world": [[r00,r01,r02,tx],[r10,r11,r12,ty],[r20,r21,r22,tz],[0,0,0,1]] },
//           { "frame": 1, "position": [x, y, z], "yaw": 0.1, "pitch": 0.0, "roll": 0.0 },
//           { "frame": 2, "position": [x, y, z], "quaternion": [w, x, y, z] } ] } ]
//   }
//
// Paths are relative to the JSON file's folder. Matrices are row-major
// (numpy's tolist() of a [4,4] array). yaw/pitch/roll (radians, pitch and roll
// optional) give R = Rz(yaw)·Ry(pitch)·Rx(roll) as scene::box_rotation does; a
// quaternion must be unit within 1e-3 and is normalised. Frames are integers
// 0..frames−1, each at most once per track; an object is absent in the frames
// its track does not list. Unknown keys are errors (typos would otherwise be
// silently ignored). Poses must be rigid: |RᵀR − I| <= 1e-6 per element,
// det R > 0, bottom row (0, 0, 0, 1), all finite.
// Every error is one line "file: /json/pointer: what" (scene::InputError),
// naming the Gaussian file and its Gaussian for errors inside it.
//
// Placement of a Gaussian by T = [R | t]: position p' = R·p + t (double),
// rotation q' = q_R ⊗ q (so Σ' = R·Σ·Rᵀ), scale and opacity unchanged, SH
// coefficients of degree l = 1..3 rotated exactly: colour'(R·d) = colour(d)
// for every direction d (per-degree real-SH rotation matrices in the
// renderer's basis, solved in double from sampled directions; exact because
// each degree's span is closed under rotation).
// Tests: tests/splat/test_splat_scene.cpp.
#pragma once

#include "splat/gaussians.h"

#include <glm/glm.hpp>

#include <array>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace icube::splat {

inline constexpr const char* kSplatSceneFormat = "icube-splat-scene";
inline constexpr int kSplatSceneVersion = 1;

struct SplatObject {
  int64_t id = 0;
  std::string source;                  // the Gaussian file, as resolved
  GaussianCloud gaussians;             // in the object frame
  std::vector<glm::dmat4> poses;       // object_to_world per frame (identity where absent)
  std::vector<uint8_t> present;        // 1 where the track lists the frame; same size as poses

  // object_to_world at `frame`, or nullptr when the object is absent there (or frame >= poses.size()).
  const glm::dmat4* pose(size_t frame) const {
    return frame < present.size() && present[frame] ? &poses[frame] : nullptr;
  }
};

struct SplatScene {
  std::string source;
  GaussianCloud static_set;  // world frame
  std::vector<SplatObject> objects;
  size_t frame_count = 0;    // 0 for a static-only scene (every frame is the static set)

  size_t frames() const { return frame_count; }
  bool has_objects() const { return !objects.empty(); }
};

// .ply / .splat (a static-only scene, frames() = 0) or a scene .json, by content.
SplatScene read_splat_scene(const std::string& path);
// The JSON scene from text; `name` for messages, Gaussian paths relative to `base_dir`.
SplatScene splat_scene_from_json(std::string_view text, const std::string& name, const std::string& base_dir);

// The static set plus every object present at `frame`, placed (static first, then
// objects in file order). The SH degree is the highest among the parts; lower-degree
// parts get zero higher coefficients (same colours). Frames no track lists (including
// frame >= frames()) give the static set and the objects present there (none).
GaussianCloud compose_frame(const SplatScene& scene, size_t frame);

// The highest SH degree of the static set and every object (what a frame set holding any of them needs).
uint32_t max_sh_degree(const SplatScene& scene);

// The objects present at `frame`, placed, in file order, at SH degree `sh_degree` (at least
// theirs): compose_frame's part after the static set (renderers that keep the static set resident).
GaussianCloud compose_objects(const std::vector<SplatObject>& objects, size_t frame, uint32_t sh_degree);

// ---- placement (exposed for tests and other placers) -----------------------------

// Empty when `m` is a rigid transform (see above), else the reason.
std::string rigid_transform_error(const glm::dmat4& m);
// Unit quaternion (w, x, y, z) of a rotation matrix (Shepperd's method).
glm::dvec4 quaternion_from_rotation(const glm::dmat3& r);
// Hamilton product a ⊗ b, wxyz.
glm::dvec4 quaternion_multiply(const glm::dvec4& a, const glm::dvec4& b);

// Rotation of the SH coefficients of degree 1..3 (renderer basis, rasterizer_cpu.h sh_color):
// block[l−1] is (2l+1)×(2l+1) row-major, c'_l = block · c_l per channel.
struct ShRotation {
  std::array<std::vector<double>, 3> block;
  explicit ShRotation(const glm::dmat3& r, uint32_t max_degree = 3);
  // Rotates one Gaussian's coefficients in place (k-major, RGB; degree `degree`).
  void apply(float* coeffs, uint32_t degree) const;
};

// Appends `part` transformed by the rigid `object_to_world` to `out` (out.sh_degree must be
// >= part.sh_degree; missing higher coefficients are zero).
void append_placed(GaussianCloud& out, const GaussianCloud& part, const glm::dmat4& object_to_world);
// Appends `part` unchanged (padding SH as above).
void append_cloud(GaussianCloud& out, const GaussianCloud& part);

}  // namespace icube::splat

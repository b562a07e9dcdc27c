// Rendering appearance frames along a trajectory into the frames folder
// (frames_layout.h): the static world on the GPU once (OverlayWorld, as the
// guidance buffers), each frame's dynamic cars patched in, the procedural
// appearance renderer (appearance_gpu.h), PNG encoding on worker threads
// while the next frame renders.
// Lights: street lamps at dusk, dawn and night; headlights of the frame's
// dynamic cars at dusk, dawn, night and in rain or fog.
#pragma once

#include "render/appearance/appearance_gpu.h"
#include "render/appearance/frames_layout.h"
#include "render/buffers/trajectory.h"
#include "scene/scene.h"
#include "world/triangle_mesh.h"

#include <functional>
#include <string>

namespace icube::render {

class OverlayWorld;

struct FramesRenderOptions {
  AppearanceOptions appearance;
  uint32_t seed = 0;
  unsigned threads = 0;  // PNG encoders; 0 = hardware concurrency
  std::function<void(size_t done, size_t total)> progress;
};

struct FramesRenderStats {
  size_t frames = 0, lamps = 0, max_lights = 0;
  double render_s = 0.0, cars_s = 0.0, write_s = 0.0;
};

bool lamps_on(const AppearancePrompt& p);
bool headlights_on(const AppearancePrompt& p);
// The lights of one frame: `lamps` (street_lamps of the static world) when lamps_on, plus the
// headlights of `scene`'s dynamic cars at `time_index` when headlights_on (scene may be null).
std::vector<WorldLight> frame_lights(const AppearancePrompt& p, const std::vector<WorldLight>& lamps,
                                     const scene::Scene* scene, int time_index);

// Writes rgb/, sky_mask/, instance/ and frames_meta.json into `dir` (which must exist).
// `scene` may be null (no dynamic cars, no headlights); `static_world` is the world the overlay holds.
FramesRenderStats render_frames(gpu::Context& ctx, OverlayWorld& world, const world::VoxelGrid& static_world,
                                const scene::Scene* scene, const world::TriangleMesh& mesh,
                                const PinholeIntrinsics& K, const Trajectory& traj, const std::string& prompt,
                                const FramesRenderOptions& o, const std::string& dir);

}  // namespace icube::render

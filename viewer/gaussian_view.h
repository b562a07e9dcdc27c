// The viewer's Gaussian view of a package (icube generate's gaussians/): the
// static Gaussians resident on the GPU in chunks at two levels
// (splat/lod_gaussians_gpu.h), the moving cars placed at the time index, the
// fitted sky behind, drawn by the splatting rasterizer
// (splat/rasterizer_gpu.h) and converted to the presenter's RGBA8
// (splat/splat_rgba8.h).
// Per view, chunks outside the frustum or beyond the level of detail's
// distance are left out and far chunks drawn at the coarse level: the
// `moving` settings while the camera or the time moves (fewer Gaussians, for
// the frame rate), the `still` ones when it rests (the image as the
// package's evaluation sees it). A view whose camera, time and settings did
// not change is not drawn again: the last image stays on screen.
// Our own car (the one the user drives; the package holds only the scene's
// cars) is drawn where the caller asks: the car mesh's surface Gaussians
// (splat/mesh_gaussians.h) fitted into its box and placed at its pose.
// Time: the viewer's time index is the splat scene's frame (clamped to its
// last frame), which is the scene's time index when the package's frames
// carry scene times (lift_frames.h splat_frames_are_times).
// Tests: tests/viewer/test_gaussian_view.cpp; the scripted session viewer/check_gaussian_session.sh.
#pragma once

#include "gpu/buffer.h"
#include "gpu/commands.h"
#include "gpu/context.h"
#include "render/camera.h"
#include "splat/gaussian_lod.h"
#include "splat/lod_gaussians_gpu.h"
#include "splat/rasterizer_gpu.h"
#include "splat/sky.h"
#include "splat/splat_rgba8.h"
#include "splat/splat_scene.h"
#include "world/triangle_mesh.h"

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace icube::viewer {

// Whole: every chunk at the fine level, no culling (what `icube splat render` draws).
enum class GaussianDetail { Whole, Still, Moving };

struct GaussianViewOptions {
  splat::GaussianChunkOptions chunking = [] {
    splat::GaussianChunkOptions o;
    o.chunk_size = 12.8;  // m: half the preview's chunks, for a finer fine/coarse boundary near the camera
    return o;
  }();
  // At rest: the preview's setting without the distance cut (0.0 dB against the whole set at half
  // its frame time on the demo town, bench/README.md "Level of detail").
  splat::LodOptions still = [] {
    splat::LodOptions o;
    o.coarse_distance = 40.0;
    return o;
  }();
  // Moving: fine only in the chunks around the camera, nothing beyond 60 m (bench/README.md
  // "icube-view on Gaussians").
  splat::LodOptions moving = [] {
    splat::LodOptions o;
    o.max_distance = 60.0;
    o.coarse_distance = 2.0;
    return o;
  }();
  // Depth sort keys while moving (splat_frame.h SplatOptions::depth_key_bits): 16 halves the depth
  // sort's passes; at rest the exact 32-bit order.
  uint32_t moving_key_bits = 16;
};

struct GaussianViewStats {
  size_t static_gaussians = 0, coarse_gaussians = 0, chunks = 0, objects = 0;
  uint64_t resident_bytes = 0;
  double load_s = 0.0;
  // The last drawn view.
  size_t drawn = 0, chunks_fine = 0, chunks_coarse = 0, chunks_out = 0;
  GaussianDetail detail = GaussianDetail::Still;
  double assemble_ms = 0.0, render_ms = 0.0;
  // The rasterizer's GPU timestamps of the last drawn view. Inside icube-view on lavapipe the
  // preprocess and blend intervals read ~0.02 ms (the same view drawn by the tests reads 1-6 and
  // 15 ms): with the swapchain's framebuffer left bound on the queue's gallium context, llvmpipe
  // reads a timestamp's clock when its tile scene is next flushed (lp_setup_end_query), not at the
  // command, so an interval holding one dispatch and no barrier collapses (Mesa 22.3 source, not
  // verified by a build). A barrier right after each timestamp would fix it; the viewer reports
  // the wall clock, render_ms, instead.
  splat::SplatTimings timings;
  size_t renders = 0, reused = 0;  // views drawn / shown again unchanged
};

class GaussianView {
 public:
  // `scene_json`: an icube-splat-scene (gaussians/scene.json); `sky_png`: its equirectangular sky
  // (empty: the gradient sky).
  GaussianView(gpu::Context& ctx, const std::string& scene_json, const std::string& sky_png,
               const GaussianViewOptions& o = {});

  // Frames of the splat scene (0: static only).
  size_t frames() const { return frames_; }
  // The static set's centre (whole metres), where a viewer without a world starts.
  glm::dvec3 centre() const { return lod_->origin(); }
  const std::string& source() const { return source_; }
  GaussianViewOptions& options() { return opt_; }

  // Our car: `mesh` fitted into a length x width x height box (world/mesh_voxelize.h fit_mesh_to_box)
  // as surface Gaussians, drawn at the box-to-world pose draw() is given.
  void set_own_car(const world::TriangleMesh& mesh, double length, double width, double height);
  size_t own_car_gaussians() const { return own_car_.size(); }

  // Draws the view unless it equals the last one drawn (returns false then). Waits for the GPU;
  // the caller makes sure no earlier frame still reads the images (one frame in flight).
  // `own_car`: our car's box-to-world pose (nullptr: not drawn; needs set_own_car).
  bool draw(const render::Camera& cam, size_t time_index, GaussianDetail detail,
            const glm::dmat4* own_car = nullptr);
  // Records the conversion of the last drawn image into rgba() (packed RGBA8) when it changed.
  // The caller orders it before its copy of rgba() (compute -> transfer).
  void record_present(gpu::CommandList& cmd);
  const gpu::Buffer& rgba() const { return rgba8_; }
  uint32_t width() const { return width_; }
  uint32_t height() const { return height_; }
  // The last drawn image as RGBA8 (after record_present's submission finished).
  std::vector<uint8_t> download_rgba();
  const GaussianViewStats& stats() const { return stats_; }
  // The splat scene frame shown at a time index.
  size_t frame_of(size_t time_index) const;

 private:
  void place_objects(size_t frame, const std::optional<glm::dmat4>& own_car);

  gpu::Context& ctx_;
  GaussianViewOptions opt_;
  std::string source_;
  std::vector<splat::SplatObject> objects_;
  splat::GaussianCloud own_car_;  // box frame
  size_t frames_ = 0;
  std::unique_ptr<splat::LodGaussiansGpu> lod_;
  splat::SplatRendererGpu renderer_;
  splat::SplatToRgba8 to_rgba8_;
  splat::SplatOptions splat_opts_;
  gpu::Buffer rgba8_;
  uint32_t width_ = 0, height_ = 0;
  GaussianViewStats stats_;
  // What the last drawn image shows.
  struct Key {
    render::Camera cam;
    size_t frame = 0;
    GaussianDetail detail = GaussianDetail::Still;
    std::optional<glm::dmat4> own_car;
    bool operator==(const Key& k) const;
  };
  std::optional<Key> last_;
  // What the placed objects show: the frame and our car's pose.
  std::optional<std::pair<size_t, std::optional<glm::dmat4>>> placed_;
  // The scene's objects composed at composed_frame_ (without our car).
  splat::GaussianCloud composed_;
  std::optional<size_t> composed_frame_;
  bool converted_ = true;
};

}  // namespace icube::viewer

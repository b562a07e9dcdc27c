// Rendering a trajectory into guidance frames; see guidance_sequence.h.
#include "render/buffers/guidance_sequence.h"

#include "render/buffers/dynamic_cars.h"

#include "render/buffers/overlay_world.h"

#include <algorithm>
#include <chrono>
#include <set>
#include <stdexcept>

namespace icube::render {

namespace {
using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }
}  // namespace

GuidanceSequence render_sequence(gpu::Context& ctx, OverlayWorld& world, const scene::Scene* scene,
                                 const world::TriangleMesh& mesh, const PinholeIntrinsics& K, const Trajectory& traj,
                                 const SequenceOptions& opts) {
  if (traj.size() == 0) throw std::invalid_argument("guidance buffers: empty trajectory");
  GuidanceSequence seq;
  seq.K = K;
  seq.trajectory = traj;
  seq.pixels = opts.pixels;
  RaycasterGpu caster(ctx);
  RaycastOptions ro;
  ro.pixels = opts.pixels;
  const size_t n = static_cast<size_t>(K.width) * K.height;
  gpu::Buffer hits(ctx, n * sizeof(shader::RaycastHit), gpu::MemoryUsage::DeviceLocal, "guidance-hits");
  const glm::dmat4 inv0 = glm::inverse(traj.c2w[0]);
  const RaycastWorld& rw = world.world();
  std::set<uint16_t> ids;
  DynamicCarOverlay cars(world, scene, mesh);
  DynamicCarCosts car_costs;
  for (size_t f = 0; f < traj.size(); ++f) {
    const int ti = traj.time_index[f];
    cars.set_time(ti, car_costs);
    seq.cars_s = car_costs.cars_s;
    seq.overlay_s = car_costs.overlay_s;
    seq.max_overlay_bricks = car_costs.max_overlay_bricks;
    seq.overlay_bytes = car_costs.overlay_bytes;
    auto t0 = Clock::now();
    Camera cam;
    cam.K = K;
    cam.c2w = traj.c2w[f];
    ctx.submit_and_wait([&](gpu::CommandList& cmd) { caster.record_camera(cmd, rw, cam, ro, hits); });
    seq.cast_s += seconds_since(t0);
    t0 = Clock::now();
    const std::vector<shader::RaycastHit> h = gpu::download_vector<shader::RaycastHit>(ctx, hits, n);
    seq.download_s += seconds_since(t0);
    t0 = Clock::now();
    GuidanceFrame fr = frame_from_hits(h, K, opts.pixels);
    if (!opts.keep_normals) fr.normal.clear();
    for (uint16_t id : fr.instance)
      if (id) ids.insert(id);
    seq.frames.push_back(std::move(fr));
    seq.rel.push_back(inv0 * traj.c2w[f]);
    seq.rays += n;
    seq.post_s += seconds_since(t0);
    if (opts.progress) opts.progress(f + 1, traj.size());
  }
  const auto t0 = Clock::now();
  seq.instance_colors = instance_colors(std::vector<uint16_t>(ids.begin(), ids.end()), opts.seed);
  std::vector<const std::vector<float>*> depth;
  for (const GuidanceFrame& fr : seq.frames) depth.push_back(&fr.zdepth);
  seq.coordinates = coordinate_range(K, depth, seq.rel, opts.pixels, opts.seed);
  seq.post_s += seconds_since(t0);
  return seq;
}

}  // namespace icube::render

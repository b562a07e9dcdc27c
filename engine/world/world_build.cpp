// build_world(): plan, generate, fuse, insert vehicles (world_build.h).
#include "world/world_build.h"

#include "scene/scene.h"
#include "world/chunk_fusion.h"
#include "world/vehicle_insert.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <exception>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

namespace icube::world {

namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

glm::dvec3 world_origin_for(const ChunkPlan& plan, double vs) {
  return plan.chunks.empty() ? glm::dvec3(0.0) : world_lattice_origin(plan.chunks.front(), vs);
}

struct GeneratedChunk {
  std::optional<ChunkVoxels> voxels;
  double generate_s = 0.0;
};

// Generates every chunk, calling fuse(n, chunk) in plan order on the calling
// thread. Workers run at most 2 * threads chunks ahead of fusion, so memory
// stays bounded on long plans.
template <class Fuse>
void generate_in_order(const WorldGenerator& gen, const std::vector<ChunkRequest>& requests, int threads, Fuse&& fuse) {
  const size_t total = requests.size();
  if (threads <= 1 || total <= 1) {
    for (size_t n = 0; n < total; ++n) {
      const auto t0 = Clock::now();
      GeneratedChunk g{gen.generate(requests[n]), 0.0};
      g.generate_s = seconds_since(t0);
      fuse(n, g);
    }
    return;
  }
  const size_t window = static_cast<size_t>(threads) * 2;
  std::vector<GeneratedChunk> slots(total);
  std::mutex mu;
  std::condition_variable cv;
  size_t next = 0, fused = 0;
  bool stop = false;
  std::exception_ptr error;
  auto worker = [&] {
    for (;;) {
      size_t n;
      {
        std::unique_lock lock(mu);
        cv.wait(lock, [&] { return stop || next >= total || next < fused + window; });
        if (stop || next >= total) return;
        n = next++;
      }
      GeneratedChunk g;
      try {
        const auto t0 = Clock::now();
        g.voxels = gen.generate(requests[n]);
        g.generate_s = seconds_since(t0);
      } catch (...) {
        std::lock_guard lock(mu);
        if (!error) error = std::current_exception();
        stop = true;
        cv.notify_all();
        return;
      }
      std::lock_guard lock(mu);
      slots[n] = std::move(g);
      cv.notify_all();
    }
  };
  std::vector<std::thread> pool;
  for (int t = 0; t < threads; ++t) pool.emplace_back(worker);
  std::exception_ptr fuse_error;
  for (size_t n = 0; n < total; ++n) {
    GeneratedChunk g;
    {
      std::unique_lock lock(mu);
      cv.wait(lock, [&] { return stop || slots[n].voxels.has_value(); });
      if (stop && !slots[n].voxels) break;
      g = std::move(slots[n]);
      slots[n].voxels.reset();
    }
    try {
      fuse(n, g);
    } catch (...) {
      fuse_error = std::current_exception();
    }
    std::lock_guard lock(mu);
    ++fused;
    if (fuse_error) stop = true;
    cv.notify_all();
    if (fuse_error) break;
  }
  {
    std::lock_guard lock(mu);
    stop = true;
  }
  cv.notify_all();
  for (auto& th : pool) th.join();
  if (error) std::rethrow_exception(error);
  if (fuse_error) std::rethrow_exception(fuse_error);
}

}  // namespace

glm::dvec3 world_lattice_origin(const ChunkPose& first, double vs) { return glm::floor(chunk_centre(first) / vs + 0.5) * vs; }

bool inside_chunk(const ChunkPose& pose, const glm::dvec3& p, double margin) {
  const glm::dmat3 r(pose.chunk_to_world);
  const glm::dvec3 local = glm::transpose(r) * (p - glm::dvec3(pose.chunk_to_world[3]));
  return std::abs(local.x) <= kChunkHalfExtent.x + margin && std::abs(local.y) <= kChunkHalfExtent.y + margin &&
         std::abs(local.z) <= kChunkHalfExtent.z + margin;
}

WorldBuildResult build_world(const scene::Scene& scene, const WorldGenerator& generator,
                             const WorldBuildOptions& options) {
  const auto t_start = Clock::now();
  WorldBuildResult out;
  out.plan = plan_chunks(scene, options.mode, options.plan);
  out.plan_s = seconds_since(t_start);
  out.world = VoxelGrid(world_origin_for(out.plan, kFineVoxel), kFineVoxel);

  std::vector<ChunkRequest> requests(out.plan.chunks.size());
  for (size_t n = 0; n < requests.size(); ++n) {
    ChunkRequest& r = requests[n];
    r.scene = &scene;
    r.plan = &out.plan;
    r.chunk = n;
    r.world_origin = out.world.origin();
    r.world_voxel_size = out.world.voxel_size();
    r.world = &out.world;
    r.seed = options.seed;
  }
  int threads = options.threads > 0 ? options.threads : static_cast<int>(std::thread::hardware_concurrency());
  if (generator.reads_world()) threads = 1;
  threads = std::max(1, threads);

  out.chunks.resize(requests.size());
  generate_in_order(generator, requests, threads, [&](size_t n, GeneratedChunk& g) {
    const auto t0 = Clock::now();
    out.chunks[n].fusion = fuse_chunk(out.world, *g.voxels);
    out.chunks[n].fuse_s = seconds_since(t0);
    out.chunks[n].generate_s = g.generate_s;
    out.generate_s += g.generate_s;
    out.fuse_s += out.chunks[n].fuse_s;
    if (options.progress) options.progress(n + 1, requests.size());
  });

  if (options.insert_static_vehicles && !scene.tracks.empty()) {
    const auto t0 = Clock::now();
    const VehicleMeshSet builtin = options.vehicle_meshes ? VehicleMeshSet{} : builtin_vehicle_meshes();
    const VehicleMeshSet& meshes = options.vehicle_meshes ? *options.vehicle_meshes : builtin;
    const auto in_plan = [&](const scene::Track&, const scene::BoxState& b) {
      return std::any_of(out.plan.chunks.begin(), out.plan.chunks.end(),
                         [&](const ChunkPose& c) { return inside_chunk(c, b.center); });
    };
    const VehicleInsertStats st = insert_vehicles(out.world, scene, options.vehicle_time_index, meshes, 1, in_plan);
    out.vehicle_voxels = st.voxels;
    out.vehicles_inserted = st.vehicles;
    out.vehicles_per_type = st.per_type;
    out.vehicles_s = seconds_since(t0);
  }
  out.total_s = seconds_since(t_start);
  return out;
}

}  // namespace icube::world

// The real 0.2 m worlds the benchmarks run on: a scene's world built by the
// procedural prior (2 worker threads), and the time the build took.
#pragma once

#include "scene/scene.h"
#include "world/procedural/procedural_prior.h"
#include "world/world_build.h"

#include <chrono>

namespace icube::bench {

inline world::VoxelGrid build_procedural(const scene::Scene& sc, world::PlanMode mode, double& seconds) {
  const auto t0 = std::chrono::steady_clock::now();
  const world::ProceduralPrior prior(sc);
  world::WorldBuildOptions o;
  o.mode = mode;
  o.threads = 2;
  world::VoxelGrid g = world::build_world(sc, prior, o).world;
  seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return g;
}

}  // namespace icube::bench

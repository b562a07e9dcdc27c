// The procedural world prior: the default Stage-1 generator when no model
// weights are given. It is NOT a learned model: a deterministic, seeded set of
// rules that turns the HD map into a plausible semantic voxel world, so that
// Stages 2 and 3 have a world to work on without a diffusion model.
//
// It evaluates a world-space field (everything is a function of world x, y
// and the seed, never of the chunk), so overlapping chunks agree cell for
// cell, and emits the world's own lattice cells inside the chunk's crop box
// (ChunkVoxels with lattice_to_world = translation(world origin)).
//
// Rules (see procedural_prior.cpp and docs/ARCHITECTURE.md for the numbers):
// ROAD on the road surface (RoadSurface at 0.2 m with segment barriers),
// LANE_MARKER along road lines (dashes per line type) and crosswalk stripes,
// CURB along road edges, SIDEWALK then WALKABLE beyond them, BUILDING shells
// set back from the sidewalks, VEGETATION canopies on TREE_TRUNKs along the
// sidewalks and in parks, POLE/SIGN at stop signs, POLE/TRAFFIC_LIGHT at
// junctions without stop signs, street-light POLEs, OTHER_GROUND elsewhere.
// Nothing but ROAD and LANE_MARKER occupies a drivable column (vehicles are
// inserted by world_build.h afterwards).
#pragma once

#include "world/generator.h"
#include "world/road_surface.h"

#include <cstdint>
#include <memory>

namespace icube::world {

struct ProceduralOptions {
  double sidewalk_width_min = 2.0, sidewalk_width_max = 4.0;  // metres beyond the curb
  double building_setback_min = 3.0, building_setback_max = 8.0;  // beyond the sidewalk
  double building_height_min = 4.0, building_height_max = 18.0;
  double building_probability = 0.7;  // per parcel
  double street_tree_spacing = 9.0;   // metres along the sidewalk
  bool buildings = true, trees = true, street_furniture = true;
  double parcel_size = 18.0;          // world-space parcel lattice (a suburban lot's frontage, 15-20 m)
  double park_probability = 0.5;      // a parcel without a building becomes a tree cluster
  double street_light_spacing = 30.0; // metres along the sidewalk
};

class ProceduralPrior final : public WorldGenerator {
 public:
  // Precomputes the scene-wide data (road surface at 0.2 m, resampled map, junctions).
  ProceduralPrior(const scene::Scene& scene, const ProceduralOptions& options = {});
  ~ProceduralPrior() override;
  ProceduralPrior(const ProceduralPrior&) = delete;
  ProceduralPrior& operator=(const ProceduralPrior&) = delete;

  std::string name() const override { return "procedural"; }
  ChunkVoxels generate(const ChunkRequest& request) const override;

  const RoadSurface& road_surface() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace icube::world

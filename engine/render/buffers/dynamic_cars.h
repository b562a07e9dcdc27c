// Keeps an OverlayWorld's dynamic cars at the scene state of the frame being
// rendered, for every per-frame renderer (guidance buffers, LiDAR, viewer):
// the cars' cells are recomputed and the touched bricks re-uploaded only when
// the state changes, so consecutive frames of one state cost nothing.
#pragma once

#include "render/buffers/frame_scene.h"
#include "render/buffers/overlay_world.h"

#include <cstddef>
#include <vector>

namespace icube::render {

// What the updates cost, accumulated over a sequence.
struct DynamicCarCosts {
  double cars_s = 0.0, overlay_s = 0.0;
  size_t max_overlay_bricks = 0, overlay_bytes = 0;
};

class DynamicCarOverlay {
 public:
  // `scene` may be null (no cars: the world is rendered as it is). Both must outlive this object.
  DynamicCarOverlay(OverlayWorld& world, const scene::Scene* scene, const world::TriangleMesh& mesh);

  // Puts the cars of scene state `time_index` (-1: none) into the overlay.
  void set_time(int time_index, DynamicCarCosts& costs);

 private:
  OverlayWorld& world_;
  const scene::Scene* scene_;
  const world::TriangleMesh& mesh_;
  int cached_time_ = -2;  // no state applied yet
  std::vector<CarCell> cells_;
  CarVoxelCache cache_;
};

}  // namespace icube::render

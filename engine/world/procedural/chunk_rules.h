// One chunk of the procedural prior: builds the chunk's BEV raster (the crop
// box's world-axis bounding box plus a margin wide enough for every decision
// made about cells inside it), classifies the ground into bands by distance
// from the drivable area, places parcels, trees and street furniture, and
// emits the world-lattice cells inside the chunk's crop box.
#pragma once

#include "world/generator.h"
#include "world/procedural/scene_features.h"

namespace icube::world::procedural {

// Throws std::invalid_argument for a request without a plan or with a chunk index out of range.
ChunkVoxels generate_chunk(const SceneFeatures& features, const ChunkRequest& request);

}  // namespace icube::world::procedural

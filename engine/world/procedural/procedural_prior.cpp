// ProceduralPrior: validates the options, precomputes the scene-wide
// features once (scene_features.h) and fills each requested chunk with the
// rules of chunk_rules.h. Holds no mutable state, so generate() is thread-safe.
#include "world/procedural/procedural_prior.h"

#include "world/procedural/chunk_rules.h"
#include "world/procedural/scene_features.h"

#include <cmath>
#include <stdexcept>
#include <string>

namespace icube::world {

struct ProceduralPrior::Impl {
  Impl(const scene::Scene& s, const ProceduralOptions& o) : features(s, o) {}
  procedural::SceneFeatures features;
};

namespace {

void check_range(const char* what, double lo, double hi, double min_allowed) {
  if (!std::isfinite(lo) || !std::isfinite(hi) || lo < min_allowed || hi < lo)
    throw std::invalid_argument(std::string("ProceduralOptions: bad ") + what + " range");
}

void validate(const ProceduralOptions& o) {
  check_range("sidewalk_width", o.sidewalk_width_min, o.sidewalk_width_max, 0.0);
  check_range("building_setback", o.building_setback_min, o.building_setback_max, 0.0);
  check_range("building_height", o.building_height_min, o.building_height_max, 0.2);
  if (!(o.building_probability >= 0.0 && o.building_probability <= 1.0) ||
      !(o.park_probability >= 0.0 && o.park_probability <= 1.0))
    throw std::invalid_argument("ProceduralOptions: probabilities must lie in [0, 1]");
  if (!(o.parcel_size >= 10.0 && o.parcel_size <= 100.0))  // a building needs >= 7 m plus insets
    throw std::invalid_argument("ProceduralOptions: parcel_size must lie in [10, 100] m");
  if (!(o.street_tree_spacing >= 0.0) || !(o.street_light_spacing >= 0.0) || !std::isfinite(o.street_tree_spacing) ||
      !std::isfinite(o.street_light_spacing))
    throw std::invalid_argument("ProceduralOptions: spacings must be finite and >= 0");
}

}  // namespace

ProceduralPrior::ProceduralPrior(const scene::Scene& scene, const ProceduralOptions& options) {
  validate(options);
  impl_ = std::make_unique<Impl>(scene, options);
}

ProceduralPrior::~ProceduralPrior() = default;

ChunkVoxels ProceduralPrior::generate(const ChunkRequest& request) const {
  return procedural::generate_chunk(impl_->features, request);
}

const RoadSurface& ProceduralPrior::road_surface() const { return impl_->features.surface; }

}  // namespace icube::world

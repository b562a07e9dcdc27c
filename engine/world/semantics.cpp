#include "world/semantics.h"

namespace icube::world {

const char* semantic_class_name(uint8_t c) {
  static const char* const kNames[kNumSemanticClasses] = {
      "undefined", "car",      "truck",      "bus",        "other_vehicle", "motorcyclist", "bicyclist", "pedestrian",
      "sign",      "traffic_light", "pole",  "construction_cone", "bicycle", "motorcycle", "building", "vegetation",
      "tree_trunk", "curb",    "road",       "lane_marker", "other_ground", "walkable",     "sidewalk"};
  return c < kNumSemanticClasses ? kNames[c] : "invalid";
}

std::optional<uint8_t> semantic_class_from_name(std::string_view name) {
  for (int c = 1; c < kNumSemanticClasses; ++c)
    if (name == semantic_class_name(static_cast<uint8_t>(c))) return static_cast<uint8_t>(c);
  return std::nullopt;
}

uint8_t palette_index(uint8_t c) {
  static const uint8_t kIndex[kNumSemanticClasses] = {
      8,  // undefined
      3, 3, 3, 3,  // car, truck, bus, other vehicle
      1, 1, 1,     // motorcyclist, bicyclist, pedestrian
      0, 0,        // sign, traffic light
      9,           // pole
      0,           // construction cone
      1, 1,        // bicycle, motorcycle
      6,           // building
      4, 4,        // vegetation, tree trunk
      5,           // curb
      7,           // road
      5,           // lane marker
      7,           // other ground
      2, 2};       // walkable, sidewalk
  return c < kNumSemanticClasses ? kIndex[c] : 8;
}

}  // namespace icube::world

// The 23 Waymo LiDAR segmentation classes InfiniCube's voxel world uses, and
// the 10-entry guidance-buffer palette (../shared/reference/infinicube-conventions.md §3, §4).
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string_view>

namespace icube::world {

enum class SemanticClass : uint8_t {
  Undefined = 0,  // sky / miss
  Car = 1,
  Truck = 2,
  Bus = 3,
  OtherVehicle = 4,
  Motorcyclist = 5,
  Bicyclist = 6,
  Pedestrian = 7,
  Sign = 8,
  TrafficLight = 9,
  Pole = 10,
  ConstructionCone = 11,
  Bicycle = 12,
  Motorcycle = 13,
  Building = 14,
  Vegetation = 15,
  TreeTrunk = 16,
  Curb = 17,
  Road = 18,
  LaneMarker = 19,
  OtherGround = 20,
  Walkable = 21,
  Sidewalk = 22,
};

inline constexpr int kNumSemanticClasses = 23;

inline constexpr bool is_vehicle_class(uint8_t c) { return c >= 1 && c <= 4; }

// Lower-case names ("car", "traffic_light", ...), indexed by class id.
const char* semantic_class_name(uint8_t class_id);
// The class id of a lower-case name (1..22; "undefined" is not a class one can
// write), or nullopt.
std::optional<uint8_t> semantic_class_from_name(std::string_view name);

// Guidance-buffer palette index of a class (0..9) and the palette's RGB values.
uint8_t palette_index(uint8_t class_id);
inline constexpr std::array<std::array<uint8_t, 3>, 10> kGuidancePalette = {{
    {102, 194, 165},  // 0 sign, traffic light, construction cone
    {252, 141, 98},   // 1 motorcyclist, bicyclist, pedestrian, bicycle, motorcycle
    {141, 160, 203},  // 2 walkable, sidewalk
    {188, 128, 189},  // 3 car, truck, bus, other vehicle
    {77, 175, 74},    // 4 vegetation, tree trunk
    {255, 217, 47},   // 5 curb, lane marker
    {229, 196, 148},  // 6 building
    {179, 179, 179},  // 7 road, other ground
    {31, 120, 180},   // 8 undefined (sky / no hit)
    {204, 235, 197},  // 9 pole
}};
inline std::array<uint8_t, 3> class_color(uint8_t class_id) { return kGuidancePalette[palette_index(class_id)]; }

}  // namespace icube::world

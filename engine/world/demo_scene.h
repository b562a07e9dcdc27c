// The embedded demo scene (`icube world demo-scene`, assets/demo_scene.json):
// a small synthetic suburban town built in code by this project, so every
// stage has an input without external data.
//
// Layout (world metres, z = 0 road, flat): a 4-way junction at the origin of
// an east-west and a north-south road, each with one 3.5 m lane per direction
// (right-hand traffic) and a 2.5 m parking strip on each side, arms reaching
// kDemoArmLength from the centre. Road edges (curbs with 6 m corner radii) at
// 6 m from each road axis; a solid yellow centre line and broken white lines
// between each lane and its parking strip; crosswalks on all four arms just
// outside the junction; stop signs on the north-south (minor) road only.
// Lanes: an approach and an exit lane per arm plus 12 junction connectors
// (straight, left, right; `interpolating`), with entry/exit connectivity.
//
// Objects (10 Hz for the whole drive): 10 parked cars in the parking strips,
// 4 moving cars along lane centre lines (two on the major road, two that stop
// at the stop signs and go once the junction is clear), 2 pedestrians (one on
// the south crosswalk, one on the sidewalk). A moving car whose path ends
// (the end of its exit arm) before the drive does is invalid from then on,
// as a Waymo track that leaves the sensor range. The ego enters from the west,
// slows and turns left through the junction and leaves to the north
// (> 300 m); it is also track 0 (sdc_track_index 0). One front camera
// (waymo_front_camera, 832x480). Every coordinate is rounded to a fixed grid
// (1 mm, heading 1e-6 rad, rotation entries 1e-12) so the JSON is short and
// last-bit differences between maths libraries do not reach the file
// (tests/world/test_demo_scene.cpp checks assets/demo_scene.json byte for byte).
#pragma once

#include "scene/scene.h"

#include <glm/glm.hpp>

namespace icube::world {

inline constexpr double kDemoLaneWidth = 3.5;
inline constexpr double kDemoParkingWidth = 2.5;
inline constexpr double kDemoCurbRadius = 6.0;
inline constexpr double kDemoArmLength = 165.0;  // junction centre to the end of each arm
inline constexpr glm::dvec2 kDemoJunctionCentre{0.0, 0.0};

scene::Scene make_demo_scene();

}  // namespace icube::world

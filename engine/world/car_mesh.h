// The engine's own low-poly sedan, built in code (no mesh is copied from
// anywhere): a lofted body whose cross-sections (an octagon in y-z) follow a
// side profile with bumpers, hood, sloped windshield, roof, sloped rear window
// and trunk, plus four 12-sided wheels. Every part is a closed, consistently
// outward-wound surface, so the mesh is watertight (each edge is shared by
// exactly two triangles, once in each direction). Units metres, x = length
// (front at +x), y = width (left at +y), z = up, wheels touching z = 0;
// about 4.5 x 1.8 x 1.45 m. assets/car_simple.obj is this mesh written by
// mesh_to_obj() with car_mesh_obj_header() (tests/world/test_mesh_voxelize.cpp
// keeps it current; ICUBE_UPDATE_ASSETS=1 rewrites it).
#pragma once

#include "world/triangle_mesh.h"

#include <string>
#include <vector>

namespace icube::world {

TriangleMesh builtin_car_mesh();

// The comment lines at the top of assets/car_simple.obj.
std::vector<std::string> car_mesh_obj_header();

}  // namespace icube::world

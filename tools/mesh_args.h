// The mesh options `icube world build --vehicle-mesh` and `icube world insert
// --mesh` share: --mesh-axes FORWARD,UP (engine/world/vehicle_mesh.h).
#pragma once

#include "scene/input_error.h"
#include "world/vehicle_mesh.h"

#include <optional>
#include <stdexcept>
#include <string>

namespace icube::tools {

inline constexpr const char* kMeshAxesHelp =
    "File axes pointing forward and up, e.g. +z,+y (each one of +x -x +y -y +z -z); auto: glTF +z,+y (the glTF "
    "convention), PLY and OBJ +x,+z (InfiniCube's car.ply)";

// "auto" (or empty): nullopt, the format's default.
inline std::optional<world::MeshAxes> mesh_axes_arg(const std::string& text) {
  if (text.empty() || text == "auto") return std::nullopt;
  const auto axes = world::parse_mesh_axes(text);
  if (!axes)
    throw std::invalid_argument("--mesh-axes '" + scene::printable(text) +
                                "': expected FORWARD,UP, each one of +x -x +y -y +z -z on different axes, e.g. +z,+y");
  return axes;
}

// "<file> (glTF, axes +z,+y, 1234 triangles)"
inline std::string describe_mesh(const std::string& path, const world::VehicleMeshFile& f) {
  return path + " (" + world::mesh_format_name(f.format) + ", axes " + world::mesh_axes_name(f.axes) + ", " +
         std::to_string(f.mesh.triangles.size()) + " triangles)";
}

}  // namespace icube::tools

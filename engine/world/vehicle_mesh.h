// A user's vehicle (or any object) mesh in the engine's object frame:
// x = forward (length), y = left (width), z = up (height), the frame
// fit_mesh_to_box() maps onto a box's length, width and height.
//
// Files name their own axes: glTF assets face +z with +y up (glTF 2.0 spec,
// "Coordinate System and Units"); PLY and OBJ have no convention and are
// taken as InfiniCube's car.ply is, forward +x and up +z. MeshAxes names the
// file axes that point forward and up ("+z,+y"); left is up x forward, so
// the change of frame is a rotation (never a mirror) and keeps the winding.
// Units do not matter: the mesh is scaled per axis to each box.
#pragma once

#include "world/triangle_mesh.h"

#include <optional>
#include <string>
#include <string_view>

namespace icube::world {

struct SignedAxis {
  int axis = 0;  // 0 = x, 1 = y, 2 = z
  bool negative = false;
  bool operator==(const SignedAxis&) const = default;
};

struct MeshAxes {
  SignedAxis forward{0, false}, up{2, false};
  bool operator==(const MeshAxes&) const = default;
};

// The convention of a format (above).
MeshAxes default_mesh_axes(MeshFormat format);
// "FORWARD,UP" with each one of +x -x +y -y +z -z (the sign may be left out:
// "z,y"); nullopt when malformed or when both name the same axis.
std::optional<MeshAxes> parse_mesh_axes(std::string_view text);
std::string mesh_axes_name(const MeshAxes& axes);  // "+z,+y"

// Rotates file coordinates into the object frame.
void orient_mesh(TriangleMesh& mesh, const MeshAxes& axes);

struct VehicleMeshFile {
  TriangleMesh mesh;  // object frame
  MeshFormat format = MeshFormat::Obj;
  MeshAxes axes;  // the ones applied
};

// load_mesh() + orient_mesh() with `axes` or the format's default. Throws
// scene::InputError "<path>: mesh: ..." when the mesh has no triangles or no
// extent along an object axis (a flat mesh cannot be fitted to a box).
VehicleMeshFile load_vehicle_mesh(const std::string& path, const std::optional<MeshAxes>& axes = std::nullopt);

}  // namespace icube::world

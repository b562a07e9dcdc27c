// Which mesh (and class) a vehicle box is voxelised with.
//
// The scene model has one ObjectType::Vehicle without car/truck/bus
// subtypes, so a VehicleMeshSet picks the type by the box's length: each
// type covers a half-open length range [min, max) in metres; ranges may not
// overlap. A box inside a range takes that type; a box outside every range
// takes the type whose range is nearest (below the shortest range: the
// shortest type; in a gap: the nearer edge, ties to the shorter type). The
// type's name is also the class its voxels get (car, truck, bus,
// other_vehicle).
//
// The per-type JSON (`icube world build --vehicle-meshes FILE`):
//   {
//     "car":   {"mesh": "car.ply",   "length": [0, 6.5]},
//     "truck": {"mesh": "truck.glb", "length": [6.5, 10], "axes": "+z,+y"},
//     "bus":   {"mesh": "bus.obj",   "length": [10, 30]}
//   }
// Keys: a vehicle class name per type (at least one). Per type: "mesh"
// (required; a PLY/OBJ/glTF path, relative to the JSON file's folder),
// "length" ([min, max] with 0 <= min < max, finite; may be left out when
// there is one type: every length), "axes" (optional, vehicle_mesh.h
// "FORWARD,UP"; default by the mesh's format). Anything else is an error.
// Errors are scene::InputError "<json>: <key>: <what>", e.g.
//   "vehicles.json: truck.length: must be [min, max] in metres with 0 <= min < max"
//   "vehicles.json: van: unknown vehicle type (car, truck, bus, other_vehicle)"
// and errors of a mesh name the mesh file (meshes are read only once the
// whole JSON has passed).
#pragma once

#include "world/semantics.h"
#include "world/triangle_mesh.h"
#include "world/vehicle_mesh.h"

#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <vector>

namespace icube::world {

struct VehicleType {
  std::string name = "car";  // a vehicle class name
  uint8_t class_id = static_cast<uint8_t>(SemanticClass::Car);
  double min_length = 0.0, max_length = std::numeric_limits<double>::infinity();
  std::string source;                      // the mesh file, or "built-in car"
  std::optional<MeshAxes> requested_axes;  // "axes" (or --mesh-axes); nullopt: by the mesh's format
  MeshAxes axes;                           // the ones applied
  TriangleMesh mesh;                       // object frame (x forward, y left, z up)
};

struct VehicleMeshSet {
  std::vector<VehicleType> types;  // sorted by min_length
  // The type for a box of this length (rule above); `types` must not be empty.
  const VehicleType& pick(double box_length) const;
};

// One type, "car", for every length: the built-in car (car_mesh.h) ...
VehicleMeshSet builtin_vehicle_meshes();
// ... or a user's mesh (--vehicle-mesh FILE [--mesh-axes F,U]).
VehicleMeshSet single_vehicle_mesh(VehicleMeshFile file, const std::string& source);

// The per-type JSON above, checked whole before any mesh is read, then the meshes loaded.
VehicleMeshSet load_vehicle_mesh_set(const std::string& json_path);
// The JSON alone (no file is read): types sorted and checked, `source`
// resolved against base_dir, meshes empty.
VehicleMeshSet parse_vehicle_mesh_set(const std::string& json_text, const std::string& name,
                                      const std::string& base_dir);

}  // namespace icube::world

// libFuzzer target for the voxel-world file parsers: the first input byte
// picks the parser (.icw world file, .npy array, .ply labelled points, and the
// vehicle-mesh readers PLY, OBJ and glTF/GLB), the rest is the file. Anything
// they cannot read must be an InputError.
#include "scene/input_error.h"
#include "world/npy.h"
#include "world/point_import.h"
#include "world/triangle_mesh.h"
#include "world/world_file.h"

#include <cstddef>
#include <cstdint>
#include <string_view>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const std::string_view bytes(reinterpret_cast<const char*>(data) + 1, size - 1);
  try {
    switch (data[0] % 6) {
      case 0: icube::world::world_from_bytes(bytes, "fuzz.icw"); break;
      case 1: icube::world::npy_from_bytes(bytes, "fuzz.npy"); break;
      case 2: icube::world::points_from_ply_bytes(bytes, "fuzz.ply"); break;
      case 3: icube::world::parse_ply(bytes, "fuzz-mesh.ply"); break;
      case 4: icube::world::parse_obj(bytes, "fuzz.obj"); break;
      default: icube::world::parse_gltf(bytes, "fuzz.glb"); break;
    }
  } catch (const icube::scene::InputError&) {
  }
  return 0;
}

// libFuzzer target for the text specs of user meshes: the first input byte
// picks the parser (the per-type vehicle-mesh JSON, which reads no file
// while parsing; the `--box` spec; `--mesh-axes`), the rest is the text.
// A bad JSON must be an InputError and a bad box an std::invalid_argument,
// each one line.
#include "scene/input_error.h"
#include "world/object_insert.h"
#include "world/vehicle_mesh.h"
#include "world/vehicle_mesh_set.h"

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <stdexcept>
#include <string>

namespace {

void one_line(const char* what) {
  if (std::string(what).find('\n') != std::string::npos) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const std::string text(reinterpret_cast<const char*>(data) + 1, size - 1);
  switch (data[0] % 3) {
    case 0:
      try {
        const icube::world::VehicleMeshSet s = icube::world::parse_vehicle_mesh_set(text, "fuzz.json", "/fuzz");
        if (s.types.empty()) std::abort();
        s.pick(4.5);
      } catch (const icube::scene::InputError& e) {
        one_line(e.what());
      }
      break;
    case 1:
      try {
        icube::world::parse_box_spec(text);
      } catch (const std::invalid_argument& e) {
        one_line(e.what());
      }
      break;
    default: icube::world::parse_mesh_axes(text); break;
  }
  return 0;
}

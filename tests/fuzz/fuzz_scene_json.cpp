// libFuzzer target for the icube scene JSON reader, all in memory.
// Bad input must end in InputError; anything else (another exception, a
// sanitizer report, a timeout, an allocation past the RSS limit) is a bug.
// A document that reads must also write, and writing is a fixpoint:
// scene_to_json(read(scene_to_json(s))) == scene_to_json(s), else abort().
// Seeds: tests/fuzz/corpus/scene_json/.
#include "scene/input_error.h"
#include "scene/scene_json.h"

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

using namespace icube::scene;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  Diagnostics diag;
  Scene scene;
  try {
    scene = scene_from_json(text, "fuzz.json", &diag);
  } catch (const InputError&) {
    return 0;
  }
  const std::string once = scene_to_json(scene);  // must not throw: what was read can be written
  const std::string twice = scene_to_json(scene_from_json(once, "fuzz-rewritten.json"));
  if (once != twice) {
    std::fprintf(stderr, "scene JSON round trip is not a fixpoint\n");
    std::abort();
  }
  return 0;
}

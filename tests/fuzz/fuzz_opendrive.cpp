// libFuzzer target: bytes -> parse_opendrive. InputError is the expected
// outcome for bad input; any other exception, crash, hang or sanitizer report
// is a finding. Samples every 1 m and allows 2e5 border samples per map (the
// reader's own limit is 2e7) so that an input's linear work stays under ~0.3 s
// with ASan and a 30-second timeout means superlinear work, not a long road.
// Seeds: tests/fuzz/corpus/opendrive/.
#include "scene/opendrive_reader.h"

#include <cstddef>
#include <cstdint>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  icube::scene::OpenDriveOptions options;
  options.sample_step = 1.0;
  options.max_points = 2.0e5;
  icube::scene::Diagnostics diag;
  try {
    (void)icube::scene::parse_opendrive(reinterpret_cast<const char*>(data), size, "fuzz.xodr", options, &diag);
  } catch (const icube::scene::InputError&) {
  }
  return 0;
}

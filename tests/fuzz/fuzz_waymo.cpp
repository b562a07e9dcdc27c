// libFuzzer target for the Waymo reader, all in memory (no temporary files).
// Each input is tried three ways:
//   1. as one serialized Scenario payload (parse_waymo_scenario);
//   2. as a TFRecord file framed without CRC checks, so that mutated bytes
//      reach the decoder, each record's payload then decoded as a Scenario;
//   3. as a TFRecord file with every CRC checked.
// InputError is the expected outcome for bad input; anything else (another
// exception, a sanitizer report, a timeout, an allocation past the RSS
// limit) is a bug. Seeds: tests/fuzz/corpus/waymo/ (raw payloads and framed files).
#include "scene/input_error.h"
#include "scene/tfrecord.h"
#include "scene/waymo_reader.h"

#include <cstddef>
#include <cstdint>

using namespace icube::scene;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  Diagnostics diag;
  try {
    parse_waymo_scenario(data, size, "fuzz.pb", "payload", &diag);
  } catch (const InputError&) {
  }
  try {
    for (const TfRecordSpan& r : frame_tfrecords(data, size, "fuzz.tfrecord", {false, false})) {
      try {
        parse_waymo_scenario(data + r.payload_offset, size_t(r.length), "fuzz.tfrecord", "record", &diag);
      } catch (const InputError&) {
      }
    }
  } catch (const InputError&) {
  }
  try {
    frame_tfrecords(data, size, "fuzz.tfrecord");
  } catch (const InputError&) {
  }
  return 0;
}

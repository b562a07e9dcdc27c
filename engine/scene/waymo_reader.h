// Reader for Waymo Open Motion Dataset `Scenario` records in TFRecord files.
//
// TFRecord framing and the protobuf wire format are decoded here (no
// generated code, no Waymo .proto files); field numbers are in
// ../shared/reference/formats.md §1. A file may hold many records back to
// back; select one by index or scenario id.
#pragma once

#include "scene/input_error.h"
#include "scene/scene.h"

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace icube::scene {

struct WaymoRecordInfo {
  uint64_t offset = 0;  // byte offset of the record's length field
  uint64_t length = 0;  // payload bytes
  std::string scenario_id;
};

// Scans the framing of every record (checking lengths and CRC32C) and decodes
// each scenario id. Throws InputError naming the file, record and byte offset.
std::vector<WaymoRecordInfo> list_waymo_records(const std::string& path);

// Reads one scenario. `selector`: empty = the first record, a decimal index,
// or a scenario id. Fills map, tracks, timestamps, sdc_track_index, ego poses
// (from the SDC track) and provenance; runs classify_tracks(). Throws
// InputError for unusable input; recoverable problems go to `diag`.
Scene read_waymo_scenario(const std::string& path, const std::string& selector = "", Diagnostics* diag = nullptr);

// Decodes one serialized Scenario message (the payload of one record).
// `file`/`where` name it in errors. Used by the reader and the fuzzer.
Scene parse_waymo_scenario(const uint8_t* data, size_t size, const std::string& file, const std::string& where,
                           Diagnostics* diag = nullptr);

}  // namespace icube::scene

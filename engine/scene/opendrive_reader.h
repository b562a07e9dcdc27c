// Reader for ASAM OpenDRIVE 1.4-1.8 maps (.xodr).
//
// Evaluates reference lines (line, arc, spiral, poly3, paramPoly3),
// elevation, superelevation, lane offsets, widths/borders and lane sections,
// then derives the engine's map layers: lane lines from road marks (with
// types), road edges from the boundaries between drivable and non-drivable
// lanes (and curbs), lane centre lines, sampled every `sample_step` metres.
// Math and gotchas: ../shared/reference/formats.md §2.
#pragma once

#include "scene/input_error.h"
#include "scene/scene.h"

#include <cstddef>
#include <string>
#include <vector>

namespace icube::scene {

struct OpenDriveOptions {
  double sample_step = 0.25;  // metres along s between samples of every border
  // Lane types that count as drivable when deriving road edges.
  std::vector<std::string> drivable_lane_types = {"driving", "entry",   "exit",    "onRamp",
                                                  "offRamp", "bidirectional", "parking", "shoulder"};
  // Build junction road edges from the union of drivable areas instead of per connecting road.
  bool junction_union_edges = true;
  // Most border samples (samples along s times borders, summed over roads) a map may need at
  // `sample_step`; larger maps are an InputError before any sampling. 2e7 is ~550 km of
  // four-lane road at 0.25 m (9 borders and centre lines per sample). The fuzz target lowers it so that each input's linear work stays far
  // under libFuzzer's timeout and a timeout means superlinear work (docs/fuzzing.md).
  double max_points = 2.0e7;
};

// Parses and samples an OpenDRIVE file. The scene has a map, provenance and
// geo_reference; `missing` lists "ego trajectory", "object boxes" and
// "cameras". Throws InputError naming the file and element (with its line).
Scene read_opendrive(const std::string& path, const OpenDriveOptions& options = {}, Diagnostics* diag = nullptr);

// The same from an in-memory document (used by the reader and the fuzzer).
Scene parse_opendrive(const char* xml, size_t size, const std::string& file, const OpenDriveOptions& options = {},
                      Diagnostics* diag = nullptr);

}  // namespace icube::scene

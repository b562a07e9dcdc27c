// `icube generate --batch SCENES.txt --shard I/N -o OUT_ROOT`: every N-th scene
// of the list starting at I, each into OUT_ROOT/<scene file stem>/. A package
// that is already complete (its manifest's hashes verify and it was made with
// the same inputs and options) is skipped, a killed run's staging folder is
// resumed, a failing scene is reported and the next one done; the shard's
// report goes to OUT_ROOT/shard-I-of-N.report.json. Exit status 1 when any
// scene failed. docs/generate.md shows Slurm job arrays and Kubernetes Indexed
// Jobs running the shards.
#pragma once

#include "generate_job.h"

#include <string>
#include <vector>

namespace icube::tools {

struct BatchScene {
  size_t line = 0;      // 1-based line in the list
  std::string scene;    // path (relative ones resolved against the list's folder)
  std::string package;  // folder name under OUT_ROOT
};

// Non-empty lines that do not start with '#'; throws "LIST:LINE: ..." on a
// duplicate package name or an empty list.
std::vector<BatchScene> read_batch_list(const std::string& list);

struct Shard {
  size_t index = 0, count = 1;
};
// "I/N" with 0 <= I < N.
Shard parse_shard(const std::string& text);

// Runs the shard; returns the number of scenes that failed.
size_t run_generate_batch(const pipeline::GenerateArgs& base, const std::string& list, const Shard& shard);

}  // namespace icube::tools

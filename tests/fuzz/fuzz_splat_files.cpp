// libFuzzer target for the Stage-3 and Stage-2 file readers that take user
// files: the first input byte picks the reader (3DGS .ply Gaussians, antimatter15
// .splat, the icube-splat-scene JSON, and the trajectory files `icube buffers
// --trajectory` reads: icube-trajectory JSON and [N,4,4] / [P,N,4,4] .npy poses),
// the rest is the file. Anything they cannot read must be an InputError;
// another exception, a sanitizer report or a timeout is a bug.
// Seeds: tests/fuzz/corpus/splat_files/ (first byte = reader).
#include "render/buffers/trajectory.h"
#include "scene/input_error.h"
#include "splat/gaussians.h"
#include "splat/splat_format.h"
#include "splat/splat_scene.h"

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <string>
#include <string_view>

namespace {
// The trajectory readers take paths: the input goes through one temporary file per process.
std::string temp_path(const char* ext) {
  return "/tmp/icube-fuzz-" + std::to_string(::getpid()) + ext;
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const std::string_view bytes(reinterpret_cast<const char*>(data) + 1, size - 1);
  try {
    switch (data[0] % 5) {
      case 0: icube::splat::gaussians_from_ply_bytes(bytes, "fuzz.ply"); break;
      case 1: icube::splat::gaussians_from_splat_bytes(bytes, "fuzz.splat"); break;
      case 2: icube::splat::splat_scene_from_json(bytes, "fuzz-scene.json", "/nonexistent-fuzz-dir"); break;
      default: {
        const std::string path = temp_path(data[0] % 5 == 3 ? ".json" : ".npy");
        if (std::FILE* f = std::fopen(path.c_str(), "wb")) {  // no fsync: millions of runs
          std::fwrite(bytes.data(), 1, bytes.size(), f);
          std::fclose(f);
        }
        icube::render::load_trajectory(path, data[0] % 2 ? 0 : 91);
        std::remove(path.c_str());
        break;
      }
    }
  } catch (const icube::scene::InputError&) {
  }
  return 0;
}

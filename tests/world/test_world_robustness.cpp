// Mutated .icw, .npy and .ply inputs (fixed seeds): every reader either
// succeeds or throws scene::InputError, never anything else and never crashes.
// The .icw mutations re-seal the CRC so they reach the structural checks.
#include <doctest/doctest.h>

#include "scene/input_error.h"
#include "world/npy.h"
#include "world/point_import.h"
#include "world/world_export.h"
#include "world/world_file.h"

#include <cstring>
#include <functional>
#include <random>
#include <string>

using namespace icube;

namespace {

// Applies 1-4 random edits: byte overwrite, truncation, insertion or deletion.
std::string mutate(std::string s, std::mt19937& rng) {
  std::uniform_int_distribution<int> edits(1, 4), kind(0, 3), byte(0, 255);
  for (int e = edits(rng); e > 0 && !s.empty(); --e) {
    const size_t at = std::uniform_int_distribution<size_t>(0, s.size() - 1)(rng);
    switch (kind(rng)) {
      case 0: s[at] = static_cast<char>(byte(rng)); break;
      case 1: s.resize(at); break;
      case 2: s.insert(at, 1, static_cast<char>(byte(rng))); break;
      default: s.erase(at, 1); break;
    }
  }
  return s;
}

// Runs `parse` on `n` mutations of `good`; returns how many were rejected (InputError).
int fuzz(const std::string& good, int n, uint32_t seed, const std::function<void(const std::string&)>& parse,
         const std::function<std::string(std::string)>& fix = nullptr) {
  std::mt19937 rng(seed);
  int rejected = 0;
  for (int i = 0; i < n; ++i) {
    std::string m = mutate(good, rng);
    if (fix) m = fix(std::move(m));
    try {
      parse(m);
    } catch (const scene::InputError&) {
      ++rejected;
    } catch (const std::exception& e) {
      FAIL_CHECK("mutation " << i << " threw a non-InputError: " << e.what());
    }
  }
  return rejected;
}

}  // namespace

TEST_CASE("world readers survive mutated inputs") {
  world::VoxelGrid g(glm::dvec3(5.0, -3.0, 1.0));
  std::mt19937 rng(5);
  std::uniform_int_distribution<int> d(-20, 20), c(1, 22);
  for (int i = 0; i < 300; ++i) g.set({d(rng), d(rng), d(rng)}, static_cast<uint8_t>(c(rng)), static_cast<uint16_t>(i));
  const std::string icw = world::world_to_bytes(g);
  auto reseal = [](std::string s) {
    if (s.size() >= 8) {
      const uint32_t crc = world::crc32(std::string_view(s).substr(0, s.size() - 4));
      std::memcpy(s.data() + s.size() - 4, &crc, 4);
    }
    return s;
  };
  const int icw_rejected = fuzz(icw, 3000, 1, [](const std::string& s) { world::world_from_bytes(s, "m.icw"); }, reseal);
  CHECK(icw_rejected > 2000);
  // Without resealing the CRC every mutation is caught.
  CHECK(fuzz(icw, 500, 2, [](const std::string& s) { world::world_from_bytes(s, "m.icw"); }) == 500);

  const std::string npy =
      world::npy_to_bytes(world::NpyArray::make<float>({4, 5}, std::vector<float>(20, 1.0f)));
  const int npy_rejected = fuzz(npy, 3000, 3, [](const std::string& s) { world::npy_from_bytes(s, "m.npy"); });
  CHECK(npy_rejected > 1000);

  const std::string ply = world::world_to_ply_bytes(g);
  const int ply_rejected = fuzz(ply, 3000, 4, [](const std::string& s) {
    world::voxelize_points(world::points_from_ply_bytes(s, "m.ply"), glm::dvec3(0.0), 0.2, "m.ply");
  });
  CHECK(ply_rejected > 300);
  const std::string ascii =
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
      "property int class\nproperty int instance\nend_header\n1 2 3 4 5\n-1 -2 -3 22 65535\n0.5 0.5 0.5 0 0\n";
  const int ascii_rejected = fuzz(ascii, 3000, 5, [](const std::string& s) { world::points_from_ply_bytes(s, "m.ply"); });
  CHECK(ascii_rejected > 300);
  MESSAGE("rejected: icw " << icw_rejected << "/3000, npy " << npy_rejected << "/3000, ply " << ply_rejected
                           << "/3000, ascii ply " << ascii_rejected << "/3000");
}

// Test helpers shared by the tests that build procedural worlds.
#pragma once

#include "world/generator.h"

#include <cstddef>
#include <string>

namespace icube::test {

// A generator that runs `inner` on the first `limit` chunks of a plan only
// and leaves the rest empty (keeps GPU tests on a small world fast).
class FirstChunks : public world::WorldGenerator {
 public:
  FirstChunks(const world::WorldGenerator& inner, size_t limit) : inner_(inner), limit_(limit) {}
  std::string name() const override { return "first-chunks"; }
  world::ChunkVoxels generate(const world::ChunkRequest& r) const override {
    if (r.chunk >= limit_) return {};
    return inner_.generate(r);
  }

 private:
  const world::WorldGenerator& inner_;
  size_t limit_;
};

}  // namespace icube::test

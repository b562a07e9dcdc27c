// The demo town, its world and procedural frames 20:36:2 at a 208 x 120
// camera, made once per test binary for the lift CLI tests (each test writes
// its outputs under its own names in the same folder).
#pragma once

#include <doctest/doctest.h>

#include "cli_test_util.h"

#include <filesystem>
#include <string>

namespace icube::test {

struct LiftDemoFrames {
  TempDir dir{"lift-demo"};
  std::string scene, world;
  std::filesystem::path frames;
  bool ok = false;
  LiftDemoFrames() {
    scene = (dir.path / "scene.json").string();
    world = (dir.path / "world.icw").string();
    frames = dir.path / "frames";
    ok = run_icube("world demo-scene -o '" + scene + "'", dir.path).code == 0 &&
         run_icube("world build '" + scene + "' -o '" + world + "'", dir.path).code == 0 &&
         run_icube("frames render '" + world + "' --scene '" + scene +
                       "' --camera 180,180,104,60,208,120 --frames 20:36:2 -o '" + frames.string() + "'",
                   dir.path)
                 .code == 0;
  }
};

inline const LiftDemoFrames& lift_demo_frames() {
  static const LiftDemoFrames d;
  REQUIRE(d.ok);
  return d;
}

}  // namespace icube::test

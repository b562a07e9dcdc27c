// The layers of docs/ARCHITECTURE.md are enforced by the build
// (cmake/IcubeModules.cmake): a library's public include path holds only its
// own module, so with icube_nn's include paths (nn, kernels, scene, gpu) a
// header of engine/nn compiles and one of a module above it (lift, render) or
// beside it (world) is not found. Compiled here with the build's compiler
// front end, syntax only.
#include <doctest/doctest.h>

#include "cli_test_util.h"

#include <filesystem>
#include <fstream>
#include <string>

using namespace icube;
namespace fs = std::filesystem;

TEST_CASE("build: a module's include paths reach its dependencies, not the modules above it") {
  const fs::path modules = test::icube_binary().parent_path() / "module-include";
  REQUIRE(fs::is_directory(modules / "nn" / "nn"));
  test::TempDir dir("module-boundaries");
  // The compiler's exit status and what it said.
  auto compile = [&](const std::string& include) {
    const fs::path probe = dir.path / "probe.cpp";
    std::ofstream(probe) << "#include \"" << include << "\"\nint main() { return 0; }\n";
    std::string cmd = "c++ -std=c++17 -fsyntax-only";
    for (const char* m : {"nn", "kernels", "scene", "gpu"}) cmd += " -I'" + (modules / m).string() + "'";
    return test::run_shell(cmd + " '" + probe.string() + "' 2>&1");
  };
  const auto [ok_code, ok_out] = compile("nn/param_spec.h");
  INFO(ok_out);
  CHECK(ok_code == 0);
  for (const char* above : {"lift/lift_frames.h", "render/raycast_gpu.h", "world/voxel_grid.h"}) {
    const auto [code, out] = compile(above);
    INFO(above << ": " << out);
    CHECK(code != 0);
    CHECK(out.find(std::string(above) + ": No such file or directory") != std::string::npos);
  }
}

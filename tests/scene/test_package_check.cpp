// check_package on a hand-made package: complete; then each way a package is
// partial or corrupt (no manifest, another format or version, a listed file
// missing, one changed byte, an unlisted file, an entry escaping the folder),
// each named with its file.
#include <doctest/doctest.h>

#include "cli_test_util.h"
#include "scene/atomic_file.h"
#include "scene/package_check.h"
#include "scene/sha256.h"

#include <nlohmann/json.hpp>

#include <filesystem>
#include <string>

using namespace icube;
namespace fs = std::filesystem;

namespace {

void write_manifest(const fs::path& root, const nlohmann::json& m) {
  scene::write_file_atomic((root / "manifest.json").string(), m.dump());
}

}  // namespace

TEST_CASE("package check: complete, then partial or corrupt in every way, each named") {
  test::TempDir dir("pkgcheck");
  const fs::path root = dir.path / "pkg";
  fs::create_directories(root / "frames");
  scene::write_file_atomic((root / "world.icw").string(), "world bytes");
  scene::write_file_atomic((root / "frames" / "000000.png").string(), "frame bytes");
  nlohmann::json m = {{"format", "icube-package"}, {"version", 1}, {"fingerprint", "abc"}};
  m["files"] = {{"world.icw", scene::sha256_hex("world bytes")}, {"frames/000000.png", scene::sha256_hex("frame bytes")}};
  write_manifest(root, m);
  scene::PackageCheck c = scene::check_package(root.string());
  CHECK_MESSAGE(c.complete, c.problem);
  CHECK(c.files == 2);
  CHECK(c.fingerprint == "abc");

  SUBCASE("no manifest") {
    fs::remove(root / "manifest.json");
    c = scene::check_package(root.string());
    CHECK_FALSE(c.complete);
    CHECK(c.problem.find("manifest.json: missing") != std::string::npos);
  }
  SUBCASE("not a folder") {
    c = scene::check_package((dir.path / "none").string());
    CHECK_FALSE(c.complete);
    CHECK(c.problem.find("none: not a folder") != std::string::npos);
  }
  SUBCASE("manifest not JSON, another format, another version") {
    scene::write_file_atomic((root / "manifest.json").string(), "{\"format\": ");
    CHECK(scene::check_package(root.string()).problem.find("not JSON") != std::string::npos);
    nlohmann::json o = m;
    o["format"] = "something-else";
    write_manifest(root, o);
    CHECK(scene::check_package(root.string()).problem.find("\"format\"") != std::string::npos);
    o = m;
    o["version"] = 2;
    write_manifest(root, o);
    CHECK(scene::check_package(root.string()).problem.find("\"version\" is not 1") != std::string::npos);
  }
  SUBCASE("a listed file missing") {
    fs::remove(root / "frames" / "000000.png");
    c = scene::check_package(root.string());
    CHECK_FALSE(c.complete);
    CHECK(c.problem.find("000000.png: listed in the manifest but missing") != std::string::npos);
  }
  SUBCASE("one changed byte: found with hashes, not by the quick check") {
    scene::write_file_atomic((root / "world.icw").string(), "world bytez");
    c = scene::check_package(root.string());
    CHECK_FALSE(c.complete);
    CHECK(c.problem.find("world.icw: SHA-256 differs") != std::string::npos);
    CHECK(scene::check_package(root.string(), false).complete);
  }
  SUBCASE("an unlisted file") {
    scene::write_file_atomic((root / "frames" / "extra.png").string(), "x");
    c = scene::check_package(root.string());
    CHECK_FALSE(c.complete);
    CHECK(c.problem.find("extra.png: not listed in the manifest") != std::string::npos);
  }
  SUBCASE("an entry that leaves the folder") {
    nlohmann::json o = m;
    o["files"]["../outside"] = scene::sha256_hex("");
    write_manifest(root, o);
    c = scene::check_package(root.string());
    CHECK_FALSE(c.complete);
    CHECK(c.problem.find("bad entry") != std::string::npos);
  }
}

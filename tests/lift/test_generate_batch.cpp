// `icube generate --batch --shard` and `--resume` end to end at a small camera:
// three shards run at once as processes over a list of four scenes (their
// union is the list, no scene done twice); a shard killed (SIGKILL) after a
// stage finishes on re-run from there, with the same bytes as an uninterrupted
// run; a re-run of every shard skips the complete packages; a corrupted
// package is generated again; bad lists and shards are refused.
#include <doctest/doctest.h>

#include "cli_test_util.h"
#include "scene/atomic_file.h"
#include "scene/package_check.h"

#include <nlohmann/json.hpp>

#include <filesystem>
#include <map>
#include <string>

using namespace icube;
namespace fs = std::filesystem;

namespace {

nlohmann::json read_json(const fs::path& p) { return nlohmann::json::parse(scene::read_file(p.string())); }

// package name -> status, over the reports of shards 0..2 of 3.
std::map<std::string, std::string> statuses(const fs::path& out, size_t* rows = nullptr) {
  std::map<std::string, std::string> s;
  size_t n = 0;
  for (int i = 0; i < 3; ++i) {
    const nlohmann::json r = read_json(out / ("shard-" + std::to_string(i) + "-of-3.report.json"));
    for (const auto& row : r["scenes"]) {
      s[row["package"].get<std::string>()] = row["status"].get<std::string>();
      ++n;
    }
  }
  if (rows) *rows = n;
  return s;
}

}  // namespace

TEST_CASE("cli: icube generate --batch: three shards cover the list once, a killed shard resumes, complete packages are skipped" *
          doctest::test_suite("slow-gpu")) {
  test::TempDir dir("batch");
  const fs::path scene = dir.path / "scenes" / "a.json";
  fs::create_directories(scene.parent_path());
  REQUIRE(test::run_icube("world demo-scene -o '" + scene.string() + "'", dir.path).code == 0);
  for (const char* n : {"b", "c", "d"}) fs::copy_file(scene, dir.path / "scenes" / (std::string(n) + ".json"));
  const fs::path list = dir.path / "scenes.txt", out = dir.path / "out";
  scene::write_file_atomic(list.string(), "# four scenes\nscenes/a.json\n\n  scenes/b.json\nscenes/c.json\n" +
                                              (dir.path / "scenes" / "d.json").string() + "\n");
  const std::string icube = test::icube_binary().string();
  const std::string opts = " generate --camera 180,180,104,60,208,120 --frames 20:30:2 --key-every 2 --no-video --no-preview -o '" +
                           out.string() + "' --batch '" + list.string() + "'";
  auto shard_cmd = [&](int i) {
    return icube + opts + " --shard " + std::to_string(i) + "/3 > '" + (dir.path / ("log" + std::to_string(i))).string() +
           "' 2>&1";
  };

  // Shard 0 (scenes a and d) is killed right after a's frames stage; shards 1 and 2 run beside it.
  const auto [code, text] = test::run_shell("cd '" + dir.path.string() + "' && ( ICUBE_GENERATE_KILL_AFTER=frames " +
                                            shard_cmd(0) + " & " + shard_cmd(1) + " & " + shard_cmd(2) +
                                            " & wait )");
  const std::string log1 = scene::read_file((dir.path / "log1").string()), log2 = scene::read_file((dir.path / "log2").string());
  INFO(text, "\nshard 1:\n", log1, "\nshard 2:\n", log2);
  CHECK_FALSE(fs::exists(out / "shard-0-of-3.report.json"));  // killed: no report
  CHECK_FALSE(fs::exists(out / "a"));                         // nothing that looks complete
  CHECK(fs::is_regular_file(out / ".a.partial" / ".stages.json"));
  CHECK_FALSE(fs::exists(out / "d"));
  for (const char* n : {"b", "c"}) CHECK_MESSAGE(scene::check_package((out / n).string()).complete, n);

  // The re-run of shard 0 continues a after its frames and does d.
  REQUIRE(test::run_shell(shard_cmd(0)).first == 0);
  size_t rows = 0;
  std::map<std::string, std::string> s = statuses(out, &rows);
  CHECK(rows == 4);  // each scene in exactly one shard
  CHECK(s == std::map<std::string, std::string>{{"a", "resumed"}, {"b", "generated"}, {"c", "generated"}, {"d", "generated"}});
  CHECK(read_json(out / "shard-0-of-3.report.json")["scenes"][0]["resumed_after"] == "frames");
  CHECK_FALSE(fs::exists(out / ".a.partial"));
  for (const char* n : {"a", "b", "c", "d"}) CHECK_MESSAGE(scene::check_package((out / n).string()).complete, n);
  // The same scene bytes and options: the resumed package's files are the uninterrupted ones' bytes.
  CHECK(read_json(out / "a" / "manifest.json")["files"] == read_json(out / "d" / "manifest.json")["files"]);

  // Every shard again: all complete, nothing redone. A corrupted package is done again.
  scene::write_file_atomic((out / "c" / "gaussians" / "sky.png").string(), "broken");
  for (int i = 0; i < 3; ++i) REQUIRE(test::run_shell(shard_cmd(i)).first == 0);
  s = statuses(out);
  CHECK(s == std::map<std::string, std::string>{{"a", "skipped"}, {"b", "skipped"}, {"c", "generated"}, {"d", "skipped"}});
  CHECK(scene::check_package((out / "c").string()).complete);

  // A missing scene fails its row (named), the shard goes on and exits non-zero.
  scene::write_file_atomic(list.string(), "scenes/a.json\nscenes/missing.json\n");
  test::CliRun r = test::run_icube(opts.substr(1) + " --shard 0/1", dir.path);
  CHECK(r.code != 0);
  CHECK(r.output.find("missing.json") != std::string::npos);
  const nlohmann::json rep = read_json(out / "shard-0-of-1.report.json");
  CHECK(rep["skipped"] == 1);
  CHECK(rep["failed"] == 1);
  CHECK_FALSE(fs::exists(out / "missing"));

  // Bad lists and shards: one line naming the list and line, or the --shard text.
  scene::write_file_atomic(list.string(), "scenes/a.json\nother/a.json\n");
  r = test::run_icube(opts.substr(1), dir.path);
  CHECK(r.code != 0);
  CHECK(r.output.find("scenes.txt: line 2: package name 'a' is also line 1's") != std::string::npos);
  scene::write_file_atomic(list.string(), "# nothing\n");
  r = test::run_icube(opts.substr(1), dir.path);
  CHECK(r.code != 0);
  CHECK(r.output.find("lists no scene") != std::string::npos);
  for (const char* bad : {"3/3", "1", "-1/2", "a/b", "0/0"}) {
    r = test::run_icube(opts.substr(1) + " --shard " + bad, dir.path);
    CHECK(r.code != 0);
    CHECK_MESSAGE(r.output.find("expected I/N") != std::string::npos, bad);
  }
}

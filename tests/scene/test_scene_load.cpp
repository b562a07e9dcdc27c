// Opening scene files by content (engine/scene/scene_load.h): JSON, TFRecord
// framing CRC and the OpenDRIVE root element decide; the extension only
// breaks ties for empty or damaged files; unknown formats list the
// supported ones.
#include "gpu_test_context.h"
#include "scene/scene_json.h"
#include "scene/scene_load.h"

#include <doctest/doctest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <unistd.h>

using namespace icube::scene;
namespace fs = std::filesystem;

namespace {

// A scratch folder for one test case, removed afterwards.
struct TempDir {
  fs::path dir;
  explicit TempDir(const char* name)
      : dir(fs::temp_directory_path() / ("icube-test-" + std::string(name) + "-" + std::to_string(::getpid()))) {
    fs::remove_all(dir);
    fs::create_directories(dir);
  }
  ~TempDir() { fs::remove_all(dir); }
  std::string write(const std::string& name, const std::string& bytes) const {
    const fs::path p = dir / name;
    std::ofstream(p, std::ios::binary) << bytes;
    return p.string();
  }
};

// A TFRecord header for a 5-byte payload: length 5 (LE uint64) and its masked
// CRC32C, 0x3E04B2EA, computed independently of the engine (Python, from the
// definition in formats.md §1.1).
const std::string kTfRecordHeader("\x05\0\0\0\0\0\0\0\xEA\xB2\x04\x3E", 12);

const char* const kSupported =
    "supported: icube scene JSON (.json), Waymo Open Motion Dataset Scenario TFRecord (.tfrecord), "
    "OpenDRIVE 1.4-1.8 (.xodr)";

}  // namespace

TEST_CASE("scene_load: JSON is recognised by its first non-blank byte, whatever the name") {
  TempDir t("load-json");
  CHECK(detect_scene_format(t.write("a.dat", "{}")) == SceneFormat::IcubeJson);
  CHECK(detect_scene_format(t.write("b", " \n\t\r {\"format\"")) == SceneFormat::IcubeJson);
  CHECK(detect_scene_format(t.write("c.xodr", "\xEF\xBB\xBF{")) == SceneFormat::IcubeJson);  // UTF-8 BOM
}

TEST_CASE("scene_load: a TFRecord is recognised by the masked CRC32C of its length") {
  TempDir t("load-tfrecord");
  CHECK(detect_scene_format(t.write("data.bin", kTfRecordHeader + "hello")) == SceneFormat::WaymoTfRecord);
  std::string bad = kTfRecordHeader + "hello";
  bad[8] ^= 1;  // one bit of the CRC
  CHECK(detect_scene_format(t.write("damaged.bin", bad)) == SceneFormat::Unknown);
  // The extension sends a damaged file to its reader, which explains the damage.
  CHECK(detect_scene_format(t.write("damaged.tfrecord", bad)) == SceneFormat::WaymoTfRecord);
  CHECK(detect_scene_format(t.write("training.tfrecord-00000-of-01000", "")) == SceneFormat::WaymoTfRecord);
  // Implausible lengths do not count even with their matching CRC (also computed in Python):
  // 0, and 2^41 bytes.
  const std::string zero("\0\0\0\0\0\0\0\0\x29\x03\x98\x07", 12);
  CHECK(detect_scene_format(t.write("zero.bin", zero + "x")) == SceneFormat::Unknown);
  const std::string huge("\0\0\0\0\0\x02\0\0\x67\x71\x92\x63", 12);
  CHECK(detect_scene_format(t.write("huge.bin", huge + "x")) == SceneFormat::Unknown);
}

TEST_CASE("scene_load: OpenDRIVE is XML whose root element is OpenDRIVE") {
  TempDir t("load-xodr");
  CHECK(detect_scene_format(t.write("map.txt",
                                    "<?xml version=\"1.0\" standalone=\"yes\"?>\n<!-- a <comment> -->\n"
                                    "<!DOCTYPE x>\n<OpenDRIVE>\n<header/>")) == SceneFormat::OpenDrive);
  CHECK(detect_scene_format(t.write("plain", "<OpenDRIVE/>")) == SceneFormat::OpenDrive);
  CHECK(detect_scene_format(t.write("scenario.xosc", "<?xml version=\"1.0\"?><OpenSCENARIO/>")) ==
        SceneFormat::Unknown);
  CHECK(detect_scene_format(t.write("other.xodr", "<?xml version=\"1.0\"?><OpenSCENARIO/>")) ==
        SceneFormat::OpenDrive);  // named .xodr: the OpenDRIVE reader reports the wrong root
}

TEST_CASE("scene_load: the real test files are recognised") {
  const std::string data = icube::test::test_data_dir();
  if (data.empty()) return;  // skipped (or failed under ICUBE_REQUIRE_DATA=1)
  CHECK(detect_scene_format(data + "/maps/waymo/motion_data_one_scenario.tfrecord") == SceneFormat::WaymoTfRecord);
  CHECK(detect_scene_format(data + "/maps/opendrive/carla/Town01.xodr") == SceneFormat::OpenDrive);
  CHECK(detect_scene_format(data + "/maps/opendrive/esmini/velodrome.xodr") == SceneFormat::OpenDrive);
  CHECK(detect_scene_format(data + "/meshes/car.ply") == SceneFormat::Unknown);
}

TEST_CASE("scene_load: unknown formats are refused with the supported ones listed") {
  TempDir t("load-unknown");
  const std::string txt = t.write("notes.txt", "hello world, this is not a scene");
  CHECK(detect_scene_format(txt) == SceneFormat::Unknown);
  CHECK_THROWS_WITH_AS(load_scene(txt), (txt + ": not a scene file (unrecognised content); " + kSupported).c_str(),
                       InputError);
  const std::string gz = t.write("scene.json.gz", std::string("\x1F\x8B\x08\0\0\0\0\0\0\x03", 10) + "payload");
  CHECK_THROWS_WITH_AS(
      load_scene(gz), (gz + ": not a scene file (the file is gzip-compressed; decompress it first); " + kSupported).c_str(),
      InputError);
  const std::string empty = t.write("empty", "");
  CHECK_THROWS_WITH_AS(load_scene(empty), (empty + ": not a scene file (the file is empty); " + kSupported).c_str(),
                       InputError);
  const std::string xosc = t.write("s.xosc", "<OpenSCENARIO/>");
  CHECK_THROWS_WITH_AS(load_scene(xosc),
                       (xosc + ": not a scene file (XML with root element <OpenSCENARIO>, not <OpenDRIVE>); " +
                        kSupported).c_str(),
                       InputError);
}

TEST_CASE("scene_load: missing files and folders are InputErrors naming them") {
  TempDir t("load-missing");
  const std::string missing = (t.dir / "missing.json").string();
  CHECK_THROWS_WITH_AS(detect_scene_format(missing), (missing + ": cannot open: No such file or directory").c_str(),
                       InputError);
  CHECK_THROWS_WITH_AS(load_scene(t.dir.string()), (t.dir.string() + ": is a directory, not a scene file").c_str(),
                       InputError);
}

TEST_CASE("scene_load: load_scene reads scene JSON and warns about an unused record selector") {
  TempDir t("load-scene");
  Scene s;
  s.prompt = "a rainy street";
  s.map.stop_signs.push_back({4, {1, 2, 3}, {}});
  const std::string path = t.write("s.scene", scene_to_json(s));
  LoadOptions opts;
  opts.waymo_selector.assign(1, '3');  // not = "3": GCC 12 -O3 reports a false -Wrestrict (PR 105329)
  Diagnostics diag;
  const Scene back = load_scene(path, opts, &diag);
  CHECK(back.prompt == "a rainy street");
  REQUIRE(back.map.stop_signs.size() == 1);
  CHECK(back.map.stop_signs[0].position == glm::dvec3(1, 2, 3));
  CHECK(diag.warnings == std::vector<std::string>{path + ": record selector '3' ignored: not a TFRecord file"});
  // Errors come from the JSON reader, with the path.
  const std::string bad = t.write("bad.json", "{\"format\": \"icube-scene\", \"version\": 1, \"prompt\": 7}");
  CHECK_THROWS_WITH_AS(load_scene(bad), (bad + ": prompt: expected a string, got an integer").c_str(), InputError);
}

TEST_CASE("scene_load: format names") {
  CHECK(std::string(scene_format_name(SceneFormat::IcubeJson)) == "icube-json");
  CHECK(std::string(scene_format_name(SceneFormat::WaymoTfRecord)) == "waymo-tfrecord");
  CHECK(std::string(scene_format_name(SceneFormat::OpenDrive)) == "opendrive");
  CHECK(std::string(scene_format_name(SceneFormat::Unknown)) == "unknown");
}

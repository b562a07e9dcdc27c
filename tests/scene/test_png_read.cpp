// PNG decoding errors (engine/scene/png_read.h): a PNG cut at every kind of place, a wrong
// signature, an empty file and corrupt image data each get a message saying what is wrong and
// where; a whole PNG still decodes.
#include <doctest/doctest.h>

#include "scene/png_read.h"
#include "scene/png_write.h"

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

using namespace icube;

namespace {
std::string png_bytes() {
  std::vector<uint8_t> rgb(7 * 5 * 3);
  for (size_t i = 0; i < rgb.size(); ++i) rgb[i] = static_cast<uint8_t>(i * 37);
  return scene::encode_png(rgb.data(), 7, 5, 3);
}

std::string read_error(const std::string& bytes) {
  const auto path = std::filesystem::temp_directory_path() / "icube_test_png_read.png";
  std::ofstream(path, std::ios::binary) << bytes;
  try {
    scene::read_png(path.string(), 3);
  } catch (const std::runtime_error& e) {
    std::filesystem::remove(path);
    return e.what();
  }
  std::filesystem::remove(path);
  return "";
}
}  // namespace

TEST_CASE("png read: a whole PNG decodes; damaged ones say what is wrong and where") {
  const std::string png = png_bytes();
  CHECK(read_error(png).empty());
  CHECK(read_error("").find("cannot read PNG: the file is empty") != std::string::npos);
  CHECK(read_error("GIF89a....").find("not a PNG file (no PNG signature at byte 0)") != std::string::npos);
  // Cut after the IHDR chunk (8 + 25 bytes): the message of the report.
  const std::string header_only = read_error(png.substr(0, 33));
  CHECK(header_only.find("truncated: the file ends after chunk IHDR at byte 8, before any image data (IDAT)") !=
        std::string::npos);
  CHECK(read_error(png.substr(0, 20)).find("truncated: the file ends inside chunk IHDR at byte 8") != std::string::npos);
  CHECK(read_error(png.substr(0, 37)).find("end inside a chunk header at byte 33, after chunk IHDR at byte 8") !=
        std::string::npos);
  CHECK(read_error(png.substr(0, png.size() - 20)).find("truncated: the file ends inside chunk IDAT") != std::string::npos);
  // Without IEND: the image may still decode (stb reads IDAT); with a flipped byte inside IDAT it may not.
  std::string corrupt = png;
  for (size_t i = 45; i < corrupt.size() - 16; ++i) corrupt[i] = static_cast<char>(0xFF);
  const std::string c = read_error(corrupt);
  CHECK(c.find("the image data (IDAT) is corrupt or too short") != std::string::npos);
  CHECK(scene::png_problem(png.substr(0, 8)) == "truncated: no IHDR chunk");
}

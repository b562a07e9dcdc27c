// icube-bench-png: the PNG encoders of the package side by side on real
// images — engine/scene/png_write.h as it is (PngSpeed::Small and Fast), the
// candidates it chose between: stb_image_write, our own Paeth + zlib 1
// encoder, and libspng at the settings that match each (compression level,
// filter choice) — on the appearance
// frames (RGB, 8-bit), their instance maps and the buffers' depth in cm
// (grey, 16-bit) of a generated package. One thread each; a warm-up, then
// min and median of --runs runs over all images; every output decoded back
// and compared with the input pixels in the same run. See bench/README.md.
#include "bench_stats.h"

#include "scene/png_read.h"
#include "scene/png_write.h"

#include <CLI/CLI.hpp>
#include <spng.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

namespace fs = std::filesystem;
using namespace icube;

namespace {

struct Image {
  int width = 0, height = 0, channels = 0;  // channels 3 (RGB8) or 1 with 16-bit samples
  std::vector<uint8_t> rgb;
  std::vector<uint16_t> gray16;
};

// libspng at a zlib level and a filter choice (scene::encode_png_libspng).
std::string spng_encode(const Image& im, int level, int filters) {
  return scene::encode_png_libspng(im.rgb.data(), im.channels == 1 ? im.gray16.data() : nullptr, im.width, im.height,
                                   im.channels, level, filters);
}

std::string ours(const Image& im, scene::PngSpeed speed) {
  return im.channels == 3 ? scene::encode_png(im.rgb.data(), im.width, im.height, 3, speed)
                          : scene::encode_png_gray16(im.gray16.data(), im.width, im.height, speed);
}

// The decoded pixels equal the input's.
bool round_trips(const Image& im, const std::string& png, const std::string& tmp) {
  if (im.channels == 1) {
    int w = 0, h = 0;
    return scene::decode_png_gray16(png, "bench", &w, &h) == im.gray16;
  }
  {
    FILE* f = std::fopen(tmp.c_str(), "wb");
    std::fwrite(png.data(), 1, png.size(), f);
    std::fclose(f);
  }
  return scene::read_png(tmp, 3).pixels == im.rgb;
}

std::vector<fs::path> pngs_in(const fs::path& dir, size_t limit) {
  std::vector<fs::path> out;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().extension() == ".png") out.push_back(e.path());
  std::sort(out.begin(), out.end());
  if (out.size() > limit) out.resize(limit);
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app("icube-bench-png: the package's PNG encoders against libspng on a generated package's images");
  std::string package;
  int runs = 5;
  size_t images = 24;
  app.add_option("package", package, "A package from `icube generate` (frames/rgb, frames/instance)")->required();
  app.add_option("--runs", runs, "Timed runs (after one warm-up)")->capture_default_str();
  app.add_option("--images", images, "Images per set")->capture_default_str();
  CLI11_PARSE(app, argc, argv);

  struct Set {
    std::string name;
    std::vector<Image> images;
  };
  std::vector<Set> sets(2);
  sets[0].name = "frames/rgb (RGB8)";
  for (const fs::path& p : pngs_in(fs::path(package) / "frames" / "rgb", images)) {
    const scene::Image8 im = scene::read_png(p.string(), 3);
    sets[0].images.push_back({im.width, im.height, 3, im.pixels, {}});
  }
  sets[1].name = "frames/instance (grey16)";
  for (const fs::path& p : pngs_in(fs::path(package) / "frames" / "instance", images)) {
    Image im;
    im.channels = 1;
    std::string bytes;
    {
      FILE* f = std::fopen(p.c_str(), "rb");
      std::fseek(f, 0, SEEK_END);
      bytes.resize(static_cast<size_t>(std::ftell(f)));
      std::fseek(f, 0, SEEK_SET);
      if (std::fread(bytes.data(), 1, bytes.size(), f) != bytes.size()) throw std::runtime_error("short read");
      std::fclose(f);
    }
    im.gray16 = scene::decode_png_gray16(bytes, p.string(), &im.width, &im.height);
    sets[1].images.push_back(std::move(im));
  }
  struct Encoder {
    std::string name;
    std::function<std::string(const Image&)> encode;
  };
  const std::vector<Encoder> encoders = {
      {"png_write Small: 8-bit stb, 16-bit libspng 8", [](const Image& im) { return ours(im, scene::PngSpeed::Small); }},
      {"libspng zlib 8, all filters", [](const Image& im) { return spng_encode(im, 8, SPNG_FILTER_CHOICE_ALL); }},
      {"libspng zlib 6, all filters", [](const Image& im) { return spng_encode(im, 6, SPNG_FILTER_CHOICE_ALL); }},
      {"png_write Fast: 8-bit libspng 1, 16-bit ours", [](const Image& im) { return ours(im, scene::PngSpeed::Fast); }},
      {"libspng zlib 1, Paeth", [](const Image& im) { return spng_encode(im, 1, SPNG_FILTER_CHOICE_PAETH); }},
      {"libspng zlib 1, all filters", [](const Image& im) { return spng_encode(im, 1, SPNG_FILTER_CHOICE_ALL); }},
  };
  const std::string tmp = (fs::temp_directory_path() / "icube-bench-png.png").string();
  std::printf("| set | encoder | images | min ms | median ms | ms per image | MiB out | decoded = input |\n|---|---|---|---|---|---|---|---|\n");
  for (const Set& s : sets) {
    for (const Encoder& e : encoders) {
      size_t out_bytes = 0;
      bool exact = true;
      for (const Image& im : s.images) {  // warm-up and the correctness check
        const std::string png = e.encode(im);
        out_bytes += png.size();
        exact = exact && round_trips(im, png, tmp);
      }
      std::vector<double> ms;
      for (int r = 0; r < runs; ++r) {
        const auto t0 = std::chrono::steady_clock::now();
        size_t sink = 0;
        for (const Image& im : s.images) sink += e.encode(im).size();
        ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
        if (sink != out_bytes) exact = false;
      }
      const bench::Summary sm = bench::summarize(ms);
      std::printf("| %s | %s | %zu | %.1f | %.1f | %.2f | %.2f | %s |\n", s.name.c_str(), e.name.c_str(), s.images.size(),
                  sm.min_ms, sm.median_ms, sm.median_ms / static_cast<double>(s.images.size()),
                  static_cast<double>(out_bytes) / 1048576.0, exact ? "yes" : "NO");
    }
  }
  fs::remove(tmp);
  return 0;
}

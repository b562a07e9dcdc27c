// Importing a video model's frames; see frames_import.h.
#include "render/appearance/frames_import.h"

#include "render/appearance/frames_layout.h"
#include "render/buffers/tar_archive.h"
#include "scene/atomic_file.h"
#include "scene/input_error.h"
#include "scene/png_read.h"
#include "scene/png_write.h"
#include "video/mp4_reader.h"
#include "world/semantics.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>

namespace icube::render {

namespace fs = std::filesystem;

std::vector<uint8_t> resample_rgb8(const std::vector<uint8_t>& src, uint32_t sw, uint32_t sh, uint32_t dw, uint32_t dh) {
  std::vector<uint8_t> out(size_t{dw} * dh * 3);
  for (uint32_t y = 0; y < dh; ++y) {
    const double y0 = double(y) * sh / dh, y1 = double(y + 1) * sh / dh;
    for (uint32_t x = 0; x < dw; ++x) {
      const double x0 = double(x) * sw / dw, x1 = double(x + 1) * sw / dw;
      double acc[3] = {0, 0, 0}, wsum = 0;
      for (uint32_t sy = static_cast<uint32_t>(y0); sy < std::min<double>(sh, std::ceil(y1)); ++sy) {
        const double wy = std::min<double>(sy + 1, y1) - std::max<double>(sy, y0);
        for (uint32_t sx = static_cast<uint32_t>(x0); sx < std::min<double>(sw, std::ceil(x1)); ++sx) {
          const double w = wy * (std::min<double>(sx + 1, x1) - std::max<double>(sx, x0));
          const size_t i = 3 * (size_t{sy} * sw + sx);
          for (int c = 0; c < 3; ++c) acc[c] += w * src[i + static_cast<size_t>(c)];
          wsum += w;
        }
      }
      for (int c = 0; c < 3; ++c)
        out[3 * (size_t{y} * dw + x) + static_cast<size_t>(c)] =
            static_cast<uint8_t>(std::clamp(std::lround(acc[c] / wsum), 0L, 255L));
    }
  }
  return out;
}

FramesImportReport import_frames(const std::string& input, const std::string& buffers_dir, const std::string& out_dir,
                                 const FramesImportOptions& o) {
  FramesImportReport rep;
  // The buffers' clip: frame count, size, frame indices.
  const fs::path bdir(buffers_dir);
  const std::string meta_path = (bdir / "buffers_meta.json").string();
  if (!fs::exists(meta_path))
    throw scene::InputError(buffers_dir, "", "no buffers_meta.json: give the clip folder `icube buffers` wrote");
  nlohmann::json bm;
  try {
    bm = nlohmann::json::parse(scene::read_file(meta_path));
  } catch (const nlohmann::json::exception& e) {
    throw scene::InputError(meta_path, "", std::string("not valid JSON: ") + e.what());
  }
  if (!bm.contains("frames") || !bm.contains("intrinsics") || bm["intrinsics"].size() != 6)
    throw scene::InputError(meta_path, "", "missing \"frames\" or \"intrinsics\"");
  const size_t nf = bm["frames"].get<size_t>();
  const auto intr = bm["intrinsics"].get<std::vector<double>>();
  const uint32_t W = static_cast<uint32_t>(intr[4]), H = static_cast<uint32_t>(intr[5]);

  // The input frames.
  std::vector<std::vector<uint8_t>> frames;
  std::vector<std::string> names;
  uint32_t iw = 0, ih = 0;
  if (fs::is_directory(input)) {
    for (const auto& e : fs::directory_iterator(input))
      if (e.is_regular_file() && e.path().extension() == ".png") names.push_back(e.path().string());
    std::sort(names.begin(), names.end());
    if (names.empty()) throw scene::InputError(input, "", "no .png frames in the folder");
  } else if (fs::is_regular_file(input)) {
    video::DecodedVideo v = video::read_video(input);
    iw = v.width, ih = v.height;
    frames = std::move(v.frames);
    for (size_t i = 0; i < frames.size(); ++i) names.push_back(input + " frame " + std::to_string(i));
  } else {
    throw scene::InputError(input, "", "neither a folder of PNG frames nor a video file");
  }
  if (names.size() != nf)
    throw scene::InputError(input, "", std::to_string(names.size()) + " frames, but the guidance buffers in " + buffers_dir +
                                           " have " + std::to_string(nf) + "; frames are matched by index");
  // Sizes: checked for every frame before anything is written.
  auto check_size = [&](const std::string& name, uint32_t w, uint32_t h) {
    if (w == W && h == H) return;
    if (uint64_t{w} * H != uint64_t{h} * W)
      throw scene::InputError(name, "", std::to_string(w) + "x" + std::to_string(h) + " does not have the aspect ratio of the buffers' " +
                                            std::to_string(W) + "x" + std::to_string(H) + "; crop or pad it first");
    rep.rescaled = true;
  };
  if (frames.empty()) {
    for (const std::string& n : names) {
      scene::Image8 img = scene::read_png(n, 3);
      check_size(n, static_cast<uint32_t>(img.width), static_cast<uint32_t>(img.height));
      frames.push_back(std::move(img.pixels));
      if (frames.size() == 1) iw = static_cast<uint32_t>(img.width), ih = static_cast<uint32_t>(img.height);
      else if (static_cast<uint32_t>(img.width) != iw || static_cast<uint32_t>(img.height) != ih)
        throw scene::InputError(n, "", "frames differ in size (" + std::to_string(img.width) + "x" +
                                           std::to_string(img.height) + " after " + std::to_string(iw) + "x" +
                                           std::to_string(ih) + ")");
    }
  } else {
    check_size(input, iw, ih);
  }
  // Masks from the buffers.
  const std::string clip = bm.value("clip", std::string("clip"));
  std::map<std::string, std::string> inst_png;
  const std::string tar_path = (bdir / "instance_buffer_480p_front.tar").string();
  if (fs::exists(tar_path))
    for (render::TarMember& m : render::parse_tar(scene::read_file(tar_path))) inst_png[m.name] = std::move(m.data);
  else
    rep.notes.push_back("no instance_buffer_480p_front.tar in the buffers: instance/ is all 0");
  const auto sky = world::class_color(0);
  std::vector<std::vector<uint8_t>> sky_masks(nf);
  std::vector<std::vector<uint16_t>> instances(nf);
  for (size_t f = 0; f < nf; ++f) {
    const std::string sem_path = (bdir / "semantic_buffer" / frame_file_name(f)).string();
    instances[f].assign(size_t{W} * H, 0);
    char base[64];
    std::snprintf(base, sizeof(base), ".%06zu.instance_buffer.front.png", f);
    const auto it = inst_png.find(clip + base);
    if (it != inst_png.end()) {
      int w = 0, h = 0;
      instances[f] = scene::decode_png_gray16(it->second, tar_path + ":" + it->first, &w, &h);
      if (static_cast<uint32_t>(w) != W || static_cast<uint32_t>(h) != H)
        throw scene::InputError(tar_path, it->first, "instance buffer is not " + std::to_string(W) + "x" + std::to_string(H));
    }
    sky_masks[f].assign(size_t{W} * H, 0);
    if (fs::exists(sem_path)) {
      const scene::Image8 sem = scene::read_png(sem_path, 3);
      if (static_cast<uint32_t>(sem.width) != W || static_cast<uint32_t>(sem.height) != H)
        throw scene::InputError(sem_path, "", "semantic buffer is not " + std::to_string(W) + "x" + std::to_string(H));
      for (size_t i = 0; i < sky_masks[f].size(); ++i)
        sky_masks[f][i] = instances[f][i] == 0 && sem.pixels[3 * i] == sky[0] && sem.pixels[3 * i + 1] == sky[1] &&
                                  sem.pixels[3 * i + 2] == sky[2]
                              ? 255
                              : 0;
    } else if (f == 0) {
      rep.notes.push_back("no semantic_buffer/ PNGs in the buffers: sky_mask/ is all 0");
    }
  }
  // Write.
  for (const char* sub : {"rgb", "sky_mask", "instance"}) fs::create_directories(fs::path(out_dir) / sub);
  for (size_t f = 0; f < nf; ++f) {
    const std::vector<uint8_t> rgb = (iw == W && ih == H) ? frames[f] : resample_rgb8(frames[f], iw, ih, W, H);
    const std::string name = frame_file_name(f);
    const int w = static_cast<int>(W), h = static_cast<int>(H);
    scene::write_file_atomic((fs::path(out_dir) / "rgb" / name).string(), scene::encode_png(rgb.data(), w, h, 3));
    scene::write_file_atomic((fs::path(out_dir) / "sky_mask" / name).string(),
                             scene::encode_png(sky_masks[f].data(), w, h, 1));
    scene::write_file_atomic((fs::path(out_dir) / "instance" / name).string(),
                             scene::encode_png_gray16(instances[f].data(), w, h));
  }
  FramesMeta meta;
  meta.source = "import";
  meta.width = W;
  meta.height = H;
  meta.prompt = o.prompt;
  meta.parsed = parse_prompt(o.prompt);
  if (bm.contains("source_frame_indices")) meta.source_frame_indices = bm["source_frame_indices"].get<std::vector<int>>();
  if (bm.contains("source_time_indices")) meta.source_time_indices = bm["source_time_indices"].get<std::vector<int>>();
  meta.source_frame_indices.resize(nf, -1);
  meta.source_time_indices.resize(nf, -1);
  meta.K.fx = intr[0], meta.K.fy = intr[1], meta.K.cx = intr[2], meta.K.cy = intr[3];
  meta.K.width = W, meta.K.height = H;
  meta.notes = rep.notes;
  if (rep.rescaled)
    meta.notes.push_back("rescaled from " + std::to_string(iw) + "x" + std::to_string(ih) + " to " + std::to_string(W) +
                         "x" + std::to_string(H));
  scene::write_file_atomic((fs::path(out_dir) / "frames_meta.json").string(), frames_meta_json(meta));
  rep.frames = nf;
  rep.width = W;
  rep.height = H;
  return rep;
}

}  // namespace icube::render

// Importing a video model's frames; see frames_import.h.
#include "render/appearance/frames_import.h"

#include "render/appearance/frames_layout.h"
#include "render/buffers/tar_archive.h"
#include "scene/atomic_file.h"
#include "scene/input_error.h"
#include "scene/png_read.h"
#include "scene/png_write.h"
#include "video/mp4_reader.h"
#include "world/npy.h"
#include "world/semantics.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>

namespace icube::render {

namespace {

glm::dmat4 mat4_of(const world::NpyArray& a, const std::string& file, const std::string& member) {
  if (a.shape != std::vector<uint64_t>{4, 4}) throw scene::InputError(file, member, "needs a [4, 4] array");
  glm::dmat4 m(1.0);
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) {
      const double v = a.as_double(size_t(4 * r + c));
      if (!std::isfinite(v)) throw scene::InputError(file, member, "is not finite");
      m[c][r] = v;
    }
  return m;
}

// The frames' camera-to-world poses in our world frame: inverse(world_to_voxel_world.npy) · pose.tar's
// camera-to-voxel-world (float32, as InfiniCube stores it), the rotation re-orthonormalised in double
// (Gram-Schmidt on the columns) and the bottom row exactly (0, 0, 0, 1). Empty (with a note) when the
// buffers have neither file.
std::vector<glm::dmat4> buffer_poses(const std::filesystem::path& bdir, const std::string& clip, size_t nf,
                                     FramesImportReport& rep) {
  namespace fs = std::filesystem;
  const std::string tar_path = (bdir / "pose.tar").string(), w2v_path = (bdir / "world_to_voxel_world.npy").string();
  if (!fs::exists(tar_path) && !fs::exists(w2v_path)) {
    rep.notes.push_back("no pose.tar / world_to_voxel_world.npy in the buffers: no camera poses (Stage 3 needs them)");
    return {};
  }
  if (!fs::exists(tar_path)) throw scene::InputError(tar_path, "", "missing (world_to_voxel_world.npy is there)");
  if (!fs::exists(w2v_path)) throw scene::InputError(w2v_path, "", "missing (pose.tar is there)");
  const glm::dmat4 v2w = glm::inverse(mat4_of(world::read_npy(w2v_path), w2v_path, ""));
  std::map<std::string, std::string> members;
  for (render::TarMember& m : render::parse_tar(scene::read_file(tar_path))) members[m.name] = std::move(m.data);
  std::vector<glm::dmat4> poses;
  for (size_t f = 0; f < nf; ++f) {
    char base[64];
    std::snprintf(base, sizeof(base), ".%06zu.pose.front.npy", f);
    const auto it = members.find(clip + base);
    if (it == members.end()) throw scene::InputError(tar_path, clip + base, "missing: one pose per frame");
    glm::dmat4 c2w = v2w * mat4_of(world::npy_from_bytes(it->second, tar_path + ":" + it->first), tar_path, it->first);
    glm::dvec3 x(c2w[0]), y(c2w[1]);
    x = glm::normalize(x);
    y = glm::normalize(y - glm::dot(x, y) * x);
    const glm::dvec3 z = glm::cross(x, y);
    if (glm::dot(z, glm::dvec3(c2w[2])) < 0.5) throw scene::InputError(tar_path, it->first, "is not a rotation");
    c2w[0] = glm::dvec4(x, 0.0);
    c2w[1] = glm::dvec4(y, 0.0);
    c2w[2] = glm::dvec4(z, 0.0);
    c2w[3].w = 1.0;
    poses.push_back(c2w);
  }
  return poses;
}

// The segmented sky masks (see the header), one per frame at W x H (nonzero = sky); checked before
// anything is written.
std::vector<std::vector<uint8_t>> read_sky_masks(const std::string& dir, int label, size_t nf, uint32_t W, uint32_t H,
                                                 uint32_t iw, uint32_t ih) {
  if (label > 255) throw scene::InputError(dir, "", "sky label " + std::to_string(label) + " is not an 8-bit value");
  const std::vector<std::string> names = png_files(dir);
  if (names.size() != nf)
    throw scene::InputError(dir, "", std::to_string(names.size()) + " sky masks, but there are " + std::to_string(nf) +
                                         " frames; masks are matched to frames by sorted name");
  std::vector<std::vector<uint8_t>> masks;
  for (const std::string& n : names) {
    const scene::Image8 m = scene::read_png(n, 1);
    const uint32_t mw = static_cast<uint32_t>(m.width), mh = static_cast<uint32_t>(m.height);
    if (!(mw == W && mh == H) && !(mw == iw && mh == ih))
      throw scene::InputError(n, "", std::to_string(mw) + "x" + std::to_string(mh) + " is neither the buffers' " +
                                         std::to_string(W) + "x" + std::to_string(H) + " nor the frames' " +
                                         std::to_string(iw) + "x" + std::to_string(ih));
    std::vector<uint8_t> out(size_t{W} * H);
    for (uint32_t y = 0; y < H; ++y) {
      const uint32_t sy = static_cast<uint32_t>((uint64_t{y} * 2 + 1) * mh / (uint64_t{H} * 2));
      for (uint32_t x = 0; x < W; ++x) {
        const uint32_t sx = static_cast<uint32_t>((uint64_t{x} * 2 + 1) * mw / (uint64_t{W} * 2));
        const uint8_t g = m.pixels[size_t{sy} * mw + sx];
        out[size_t{y} * W + x] = (label < 0 ? g >= 128 : g == label) ? 255 : 0;
      }
    }
    masks.push_back(std::move(out));
  }
  return masks;
}

}  // namespace

namespace fs = std::filesystem;

std::vector<std::string> png_files(const std::string& dir) {
  if (!fs::is_directory(dir)) throw scene::InputError(dir, "", "is not a folder of PNG files");
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.is_regular_file() && e.path().extension() == ".png") names.push_back(e.path().string());
  std::sort(names.begin(), names.end());
  return names;
}

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
    names = png_files(input);
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
  for (const auto& m : sky_masks) rep.sky_pixels_buffers += size_t(std::count(m.begin(), m.end(), uint8_t{255}));
  if (!o.sky_masks.empty()) {
    sky_masks = read_sky_masks(o.sky_masks, o.sky_label, nf, W, H, iw, ih);
    for (const auto& m : sky_masks) rep.sky_pixels_masks += size_t(std::count(m.begin(), m.end(), uint8_t{255}));
  }
  // Poses: the buffers' camera-to-voxel-world (pose.tar, float32) back in our world frame.
  const std::vector<glm::dmat4> poses = buffer_poses(bdir, clip, nf, rep);
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
  meta.poses = poses;
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
  if (!o.sky_masks.empty()) {
    meta.sky_mask = "segmentation";
    meta.notes.push_back("sky_mask/ from " + o.sky_masks +
                         (o.sky_label < 0 ? std::string(" (binary masks)") : " (label " + std::to_string(o.sky_label) + ")"));
  }
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

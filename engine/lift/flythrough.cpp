#include "lift/flythrough.h"

#include "lift/heldout_render.h"
#include "lift/lift_frames.h"
#include "scene/atomic_file.h"
#include "scene/png_read.h"
#include "scene/png_write.h"
#include "splat/lod_gaussians_gpu.h"
#include "splat/rasterizer_gpu.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <memory>
#include <optional>

namespace icube::lift {

FlythroughResult write_flythrough(gpu::Context& ctx, const splat::SplatScene& scene, const splat::SkyImage& sky,
                                  const render::FramesMeta& meta, const std::string& frames_dir, const std::string& dir,
                                  const FlythroughOptions& o) {
  namespace fs = std::filesystem;
  const auto t0 = std::chrono::steady_clock::now();
  const size_t n = meta.poses.size(), W = meta.width, H = meta.height;
  FlythroughResult res;
  res.frames = n;
  fs::create_directories(dir);
  const uint32_t degree = splat::max_sh_degree(scene);
  // Both levels resident; per frame the picked chunks are copied on the GPU (when the picks change) and
  // the placed cars uploaded behind them.
  splat::LodGaussiansGpu lod(ctx, splat::build_gaussian_chunks(scene.static_set), degree);
  splat::SplatRendererGpu renderer(ctx);
  splat::SplatOptions so;
  so.pixels = meta.pixels;
  so.depth = false;
  so.sky = splat::sky_equirect(std::make_shared<const splat::SkyImage>(sky));
  std::optional<video::Mp4Writer> mp4;
  if (o.video) mp4.emplace((fs::path(dir) / "flythrough.mp4").string(), meta.width, meta.height, o.mp4);
  std::vector<size_t> sheet;
  const size_t k = std::min(o.sheet_frames, n);
  for (size_t i = 0; i < k; ++i) sheet.push_back((2 * i + 1) * n / (2 * k));
  std::vector<uint8_t> sheet_px(sheet.size() * W * 2 * H * 3, 0);
  const size_t SW = sheet.size() * W;
  double drawn = 0.0;
  for (size_t f = 0; f < n; ++f) {
    const render::Camera cam = frame_camera(meta, f);
    lod.set_extra(splat::compose_objects(scene.objects, splat_frame_of(meta, f), degree));
    const splat::GpuGaussians& g = lod.assemble(splat::pick_chunks(lod.chunks(), cam, o.lod).picks);
    drawn += double(g.count);
    const splat::SplatImage img = renderer.render(g, cam, so);
    const std::vector<uint8_t> rgb = splat_rgb8(img);
    if (mp4) mp4->add_frame(rgb);
    const auto at = std::find(sheet.begin(), sheet.end(), f);
    if (at != sheet.end()) {
      const size_t col = size_t(at - sheet.begin());
      const scene::Image8 ref =
          scene::read_png((fs::path(frames_dir) / "rgb" / render::frame_file_name(f)).string(), 3);
      for (size_t y = 0; y < H; ++y) {
        std::copy_n(&ref.pixels[y * W * 3], W * 3, &sheet_px[(y * SW + col * W) * 3]);
        std::copy_n(&rgb[y * W * 3], W * 3, &sheet_px[((H + y) * SW + col * W) * 3]);
      }
    }
    if (o.progress) o.progress(f + 1, n);
  }
  if (mp4) mp4->finish();
  if (!sheet.empty()) {
    // Half size (2x2 box filter): a preview, and a quarter of the bytes.
    const size_t hw = SW / 2, hh = H;  // 2H rows halved
    std::vector<uint8_t> half(hw * hh * 3);
    for (size_t y = 0; y < hh; ++y)
      for (size_t x = 0; x < hw; ++x)
        for (size_t c = 0; c < 3; ++c) {
          const size_t a = ((2 * y) * SW + 2 * x) * 3 + c, b = ((2 * y + 1) * SW + 2 * x) * 3 + c;
          half[(y * hw + x) * 3 + c] =
              uint8_t((unsigned(sheet_px[a]) + sheet_px[a + 3] + sheet_px[b] + sheet_px[b + 3] + 2) / 4);
        }
    scene::write_file_atomic((fs::path(dir) / "flythrough.png").string(),
                             scene::encode_png(half.data(), int(hw), int(hh), 3));
  }
  res.mean_gaussians = n ? drawn / double(n) : 0.0;
  res.render_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return res;
}

}  // namespace icube::lift

// Contact sheet of semantic / depth / coordinate frames; see contact_sheet.h.
#include "render/buffers/contact_sheet.h"

#include "scene/png_write.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace icube::render {

scene::Canvas contact_sheet(const GuidanceSequence& seq, const std::string& title, int columns, int thumb_width) {
  const int nf = static_cast<int>(seq.frames.size());
  const int cols = std::max(1, std::min(columns, nf));
  const int W = static_cast<int>(seq.K.width), H = static_cast<int>(seq.K.height);
  const int tw = std::max(1, std::min(thumb_width, W));
  const int th = std::max(1, static_cast<int>(std::lround(static_cast<double>(H) * tw / W)));
  constexpr int kLabel = 132, kHeader = 34, kGap = 4, kRows = 3;
  const int width = kLabel + cols * (tw + kGap) + kGap;
  const int height = kHeader + kRows * (th + kGap) + kGap;
  scene::Canvas canvas(width, height, {24, 24, 28, 255});
  canvas.draw_text(kGap, 4, title, {235, 235, 235, 255}, 1);
  const char* labels[kRows] = {"semantic", "depth", "coordinate"};
  for (int r = 0; r < kRows; ++r)
    canvas.draw_text(kGap, kHeader + r * (th + kGap) + th / 2 - 6, labels[r], {235, 235, 235, 255}, 2);
  for (int c = 0; c < cols; ++c) {
    const int f = cols == 1 ? 0 : static_cast<int>(std::lround(static_cast<double>(c) * (nf - 1) / (cols - 1)));
    const GuidanceFrame& fr = seq.frames[static_cast<size_t>(f)];
    const std::vector<float> pts = coordinate_points(seq.K, fr.zdepth, seq.rel[static_cast<size_t>(f)], seq.pixels);
    const std::vector<uint8_t> rows[kRows] = {semantic_rgb(fr, seq.instance_colors), depth_vis_rgb(fr.zdepth),
                                              encode_coordinates(pts, fr.zdepth, seq.coordinates)};
    const int x0 = kLabel + kGap + c * (tw + kGap);
    canvas.draw_text(x0, kHeader - 14, "frame " + std::to_string(seq.trajectory.frame_index[static_cast<size_t>(f)]),
                     {200, 200, 200, 255}, 1);
    for (int r = 0; r < kRows; ++r) {
      const int y0 = kHeader + r * (th + kGap);
      for (int y = 0; y < th; ++y) {
        const int sy = std::min(H - 1, y * H / th);
        for (int x = 0; x < tw; ++x) {
          const int sx = std::min(W - 1, x * W / tw);
          const size_t i = 3 * (static_cast<size_t>(sy) * static_cast<size_t>(W) + static_cast<size_t>(sx));
          const std::vector<uint8_t>& img = rows[r];
          canvas.blend(x0 + x, y0 + y, {img[i], img[i + 1], img[i + 2], 255}, 1.0);
        }
      }
    }
  }
  return canvas;
}

void write_contact_sheet(const std::string& path, const scene::Canvas& sheet) {
  scene::write_png(path, sheet.rgba().data(), sheet.width(), sheet.height(), 4);
}

}  // namespace icube::render

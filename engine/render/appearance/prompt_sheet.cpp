// Contact sheet of one view under several prompts; see prompt_sheet.h.
#include "render/appearance/prompt_sheet.h"

#include <algorithm>
#include <cmath>

namespace icube::render {

std::vector<std::string> default_sheet_prompts() {
  return {"A driving scene captured at daytime. The weather is sunny.",
          "A driving scene on a cloudy, overcast day.",
          "A driving scene at daytime. The weather is rainy, the road is wet.",
          "A driving scene in thick fog at daytime.",
          "A driving scene captured at dusk, clear weather.",
          "A driving scene at nighttime. It is snowing."};
}

scene::Canvas prompt_sheet(const std::vector<std::pair<std::string, AppearanceImage>>& tiles, const std::string& title,
                           int columns, int thumb_width) {
  const int n = static_cast<int>(tiles.size());
  const int cols = std::max(1, std::min(columns, n));
  const int rows = std::max(1, (n + cols - 1) / cols);
  const int W = n ? static_cast<int>(tiles[0].second.width) : 1, H = n ? static_cast<int>(tiles[0].second.height) : 1;
  const int tw = std::max(1, std::min(thumb_width, W));
  const int th = std::max(1, static_cast<int>(std::lround(static_cast<double>(H) * tw / W)));
  constexpr int kHeader = 30, kLabel = 18, kGap = 6;
  scene::Canvas canvas(kGap + cols * (tw + kGap), kHeader + rows * (kLabel + th + kGap), {24, 24, 28, 255});
  canvas.draw_text(kGap, 6, title, {235, 235, 235, 255}, 1);
  for (int t = 0; t < n; ++t) {
    const AppearanceImage& img = tiles[static_cast<size_t>(t)].second;
    if (static_cast<int>(img.width) != W || static_cast<int>(img.height) != H) continue;
    const int x0 = kGap + (t % cols) * (tw + kGap), y0 = kHeader + (t / cols) * (kLabel + th + kGap);
    canvas.draw_text(x0, y0 + 3, tiles[static_cast<size_t>(t)].first, {220, 220, 220, 255}, 1);
    for (int y = 0; y < th; ++y) {
      const int sy0 = y * H / th, sy1 = std::max(sy0 + 1, (y + 1) * H / th);
      for (int x = 0; x < tw; ++x) {
        const int sx0 = x * W / tw, sx1 = std::max(sx0 + 1, (x + 1) * W / tw);
        uint32_t acc[3] = {0, 0, 0}, cnt = 0;
        for (int sy = sy0; sy < sy1; ++sy)
          for (int sx = sx0; sx < sx1; ++sx) {
            const uint32_t p = img.rgba[static_cast<size_t>(sy) * static_cast<size_t>(W) + static_cast<size_t>(sx)];
            acc[0] += p & 255u, acc[1] += (p >> 8) & 255u, acc[2] += (p >> 16) & 255u;
            ++cnt;
          }
        canvas.blend(x0 + x, y0 + kLabel + y,
                     {static_cast<uint8_t>(acc[0] / cnt), static_cast<uint8_t>(acc[1] / cnt),
                      static_cast<uint8_t>(acc[2] / cnt), 255},
                     1.0);
      }
    }
  }
  return canvas;
}

}  // namespace icube::render

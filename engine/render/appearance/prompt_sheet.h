// A contact sheet of appearance frames of one view under several prompts
// (`icube frames sheet`): tiles with the prompt's parsed summary above each,
// box-filtered down to `thumb_width`.
#pragma once

#include "render/appearance/appearance_gpu.h"
#include "scene/raster.h"

#include <string>
#include <utility>
#include <vector>

namespace icube::render {

// The six looks of the README's sheet: sunny noon, overcast, rainy, foggy, dusk, snowy night.
std::vector<std::string> default_sheet_prompts();

scene::Canvas prompt_sheet(const std::vector<std::pair<std::string, AppearanceImage>>& tiles, const std::string& title,
                           int columns = 3, int thumb_width = 416);

}  // namespace icube::render

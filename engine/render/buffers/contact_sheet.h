// A contact sheet of a rendered sequence: up to `columns` evenly spaced
// frames (first and last included), rows semantic / depth (colour-mapped,
// depth_vis_rgb) / coordinate, each thumbnail nearest-neighbour scaled to at
// most `thumb_width` pixels wide, with row labels on the left, the frame
// number above each column and a title line. RGBA8 via scene::Canvas.
#pragma once

#include "render/buffers/guidance_sequence.h"
#include "scene/raster.h"

#include <string>

namespace icube::render {

scene::Canvas contact_sheet(const GuidanceSequence& seq, const std::string& title, int columns = 5, int thumb_width = 256);
void write_contact_sheet(const std::string& path, const scene::Canvas& sheet);  // PNG, atomic

}  // namespace icube::render

// Importing appearance frames made elsewhere (a video model run on the
// guidance buffers this engine wrote) into the frames folder
// (frames_layout.h), for Stage 3.
// Input: a folder of PNG frames (every *.png, sorted by name) or a video
// file (mp4; decoded with libav, video/mp4_reader.h). The frames are matched
// to the buffers' frames by index: their count must equal buffers_meta.json's
// "frames"; each frame's size must be the buffers' (intrinsics w, h) or have
// exactly the same aspect ratio (w_in * h == h_in * w), in which case it is
// area-resampled to the buffers' size; anything else is refused with a
// message naming the file and both sizes, before anything is written.
// sky_mask/ comes from the buffers' semantic colours (the palette's sky entry
// where no instance covers it), or, with sky_masks, from masks segmented from
// the frames themselves (InfiniCube runs SegFormer-B5, Cityscapes class 10 =
// sky, on the generated frames): a folder of one PNG per frame (sorted by name,
// the count must match), each either a binary mask (sky_label < 0: gray >= 128
// = sky) or an 8-bit grayscale label map (pixel == sky_label = sky; a paletted
// PNG's indices are not kept, save the labels as gray), at the buffers' size or
// at the input frames' size (nearest-sampled to the buffers'). Only such masks
// show the pixel branch (lift/pixel_branch.h) what the video model drew beyond
// the voxel world. instance/ comes from instance_buffer_480p_front.tar;
// frames_meta.json copies the buffers' frame indices and camera.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace icube::render {

struct FramesImportOptions {
  std::string prompt;     // recorded only
  std::string sky_masks;  // folder of segmented sky masks (empty: from the buffers)
  int sky_label = -1;     // < 0: binary masks; else the label map's sky value (Cityscapes: 10)
};

struct FramesImportReport {
  size_t frames = 0;
  uint32_t width = 0, height = 0;
  bool rescaled = false;
  size_t sky_pixels_buffers = 0, sky_pixels_masks = 0;  // over all frames (masks: 0 without sky_masks)
  std::vector<std::string> notes;
};

// Writes into out_dir (which must exist and be empty). Throws scene::InputError on bad input.
FramesImportReport import_frames(const std::string& input, const std::string& buffers_dir, const std::string& out_dir,
                                 const FramesImportOptions& o);

// Every regular *.png file in `dir`, sorted by name: how the import matches frames and sky masks to
// the buffers' frames by index. Throws scene::InputError when `dir` is not a folder.
std::vector<std::string> png_files(const std::string& dir);

// Area resampling of an RGB8 image (for the import's same-aspect rescale).
std::vector<uint8_t> resample_rgb8(const std::vector<uint8_t>& src, uint32_t sw, uint32_t sh, uint32_t dw, uint32_t dh);

}  // namespace icube::render

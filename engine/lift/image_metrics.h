// Image quality and geometry measures of Stage-3 evaluation (CPU):
//  - SSIM (Wang et al. 2004) of two RGB8 images in [0, 1] units: per channel
//    with an 11-tap Gaussian window of σ 1.5 (normalised), C1 = 0.01², C2 =
//    0.03², over the windows that lie wholly inside the image ("valid", as
//    pytorch_msssim.ssim(data_range=1)), averaged over windows and channels;
//    with a mask, only windows whose centre pixel is in the mask count.
//  - PSNR of two RGB8 images over a mask (heldout_render.h: psnr_from_mse).
//  - The exact Euclidean distance transform of a binary image
//    (Felzenszwalb & Huttenlocher 2012: lower envelope of parabolas per row,
//    then per column), in pixels; +inf everywhere when no pixel is set.
// Tests: tests/lift/test_image_metrics.cpp (SSIM against a PyTorch
// reference, the distance transform against brute force).
#pragma once

#include <cstdint>
#include <vector>

namespace icube::lift {

// a, b: W·H·3 RGB8. mask: W·H (non-zero = counted) or empty. Returns 1 for identical images;
// 0 when no window is counted.
double ssim_rgb8(const std::vector<uint8_t>& a, const std::vector<uint8_t>& b, uint32_t width, uint32_t height,
                 const std::vector<uint8_t>& mask = {});

// PSNR (dB) of two RGB8 images in [0, 1] units over the pixels of `mask` (W·H, non-zero = counted;
// empty: all); 99 dB for identical images or no pixel counted.
double psnr_rgb8(const std::vector<uint8_t>& a, const std::vector<uint8_t>& b, const std::vector<uint8_t>& mask = {});

// Distance (pixels) from each pixel to the nearest set pixel of `set` (W·H, non-zero = set).
std::vector<float> distance_transform(const std::vector<uint8_t>& set, uint32_t width, uint32_t height);

}  // namespace icube::lift

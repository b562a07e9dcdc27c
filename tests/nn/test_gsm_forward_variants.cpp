// The GSM's whole CPU reference beyond the one-view, one-element gsm_small case:
// a batch of two equals each element run alone (nothing leaks between batch
// elements), and two views give the same voxel Gaussians and sky token in
// either view order, with the pixel Gaussians permuted by view (the lifter's
// mean, the projected features' maximum and the sky transformer are symmetric
// in the views). The second view is the case's camera yawed by 4 degrees with
// the image mirrored; the second batch element keeps every other voxel row.
#include <doctest/doctest.h>

#include "gsm_case.h"
#include "nn/gsm/gsm_reference.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <string>
#include <tuple>

using namespace icube;

namespace {

// One element (batch index b) of a batched input.
nn::GsmInputs element_of(const nn::GsmInputs& in, int64_t b) {
  nn::GsmInputs e = in;
  const int64_t N = in.views, px = in.height * in.width;
  e.batch = 1;
  e.images = nn::CpuTensor({1, N, in.height, in.width, 3},
                           std::vector<float>(in.images.data.begin() + b * N * px * 3, in.images.data.begin() + (b + 1) * N * px * 3));
  e.masks.assign(in.masks.begin() + b * N * px * 4, in.masks.begin() + (b + 1) * N * px * 4);
  e.poses.assign(in.poses.begin() + b * N, in.poses.begin() + (b + 1) * N);
  e.intrinsics.assign(in.intrinsics.begin() + b * N, in.intrinsics.begin() + (b + 1) * N);
  const int64_t patches = in.patch_rows() * in.patch_cols();
  e.depth_patch_keep.assign(in.depth_patch_keep.begin() + b * N * patches, in.depth_patch_keep.begin() + (b + 1) * N * patches);
  e.voxel_ijk = {in.voxel_ijk[static_cast<size_t>(b)]};
  return e;
}

// The case's single view with a second one appended: the camera yawed about the grid's z axis, the image
// and masks mirrored left-right, the depth-patch draw mirrored.
nn::GsmInputs with_second_view(const nn::GsmInputs& one, bool second_first) {
  nn::GsmInputs in = one;
  const int64_t H = one.height, W = one.width;
  std::vector<float> img2(one.images.data.size());
  std::vector<uint8_t> mask2(one.masks.size());
  for (int64_t r = 0; r < H; ++r)
    for (int64_t c = 0; c < W; ++c) {
      for (int k = 0; k < 3; ++k) img2[static_cast<size_t>((r * W + c) * 3 + k)] = one.images.data[static_cast<size_t>((r * W + (W - 1 - c)) * 3 + k)];
      for (int k = 0; k < 4; ++k) mask2[static_cast<size_t>((r * W + c) * 4 + k)] = one.masks[static_cast<size_t>((r * W + (W - 1 - c)) * 4 + k)];
    }
  std::array<float, 16> pose2 = one.poses[0];
  const double a = 4.0 * 3.14159265358979 / 180.0, ca = std::cos(a), sa = std::sin(a);
  for (int col = 0; col < 3; ++col) {  // R2 = Rz(a) R
    const double x = pose2[static_cast<size_t>(col)], y = pose2[static_cast<size_t>(4 + col)];
    pose2[static_cast<size_t>(col)] = static_cast<float>(ca * x - sa * y);
    pose2[static_cast<size_t>(4 + col)] = static_cast<float>(sa * x + ca * y);
  }
  std::vector<uint8_t> keep2(one.depth_patch_keep.size());
  const int64_t pr = one.patch_rows(), pc = one.patch_cols();
  for (int64_t r = 0; r < pr; ++r)
    for (int64_t c = 0; c < pc; ++c) keep2[static_cast<size_t>(r * pc + c)] = one.depth_patch_keep[static_cast<size_t>(r * pc + (pc - 1 - c))];
  auto join = [&](const auto& first, const auto& second) {
    auto out = second_first ? second : first;
    const auto& tail = second_first ? first : second;
    out.insert(out.end(), tail.begin(), tail.end());
    return out;
  };
  in.views = 2;
  in.images = nn::CpuTensor({1, 2, H, W, 3}, join(one.images.data, img2));
  in.masks = join(one.masks, mask2);
  in.poses = join(one.poses, std::vector<std::array<float, 16>>{pose2});
  in.intrinsics = join(one.intrinsics, one.intrinsics);
  in.depth_patch_keep = join(one.depth_patch_keep, keep2);
  return in;
}

double error(const nn::CpuTensor& got, const nn::CpuTensor& want) {
  REQUIRE(got.shape == want.shape);
  return nn::cpu::max_abs_over_std(got.data, want.data);
}

}  // namespace

TEST_CASE("gsm reference: a batch of two equals each element alone") {
  const std::string dir = test::gsm_small_dir();
  if (dir.empty()) return;
  const nn::GsmConfig c = nn::read_gsm_config(dir + "config.json");
  const nn::GsmWeights w = nn::load_gsm_weights(dir + "weights.safetensors");
  const nn::GsmInputs one = nn::read_gsm_inputs(dir + "inputs");
  // Element 1: the image darkened, every other voxel row, the depth draw inverted.
  nn::GsmInputs two = one;
  two.batch = 2;
  std::vector<float> img = one.images.data;
  for (float v : one.images.data) img.push_back(0.6f * v);
  two.images = nn::CpuTensor({2, 1, one.height, one.width, 3}, img);
  two.masks.insert(two.masks.end(), one.masks.begin(), one.masks.end());
  two.poses.push_back(one.poses[0]);
  two.intrinsics.push_back(one.intrinsics[0]);
  for (uint8_t k : one.depth_patch_keep) two.depth_patch_keep.push_back(k ? 0 : 1);
  std::vector<nn::Ijk> half;
  for (size_t i = 0; i < one.voxel_ijk[0].size(); i += 2) half.push_back(one.voxel_ijk[0][i]);
  two.voxel_ijk.push_back(half);
  const nn::GsmOutputs both = nn::gsm_forward_reference(c, w, two, nullptr);
  REQUIRE(both.elements.size() == 2);
  for (int64_t b = 0; b < 2; ++b) {
    CAPTURE(b);
    const nn::GsmOutputs alone = nn::gsm_forward_reference(c, w, element_of(two, b), nullptr);
    const nn::GsmElementOutputs& x = both.elements[static_cast<size_t>(b)];
    const nn::GsmElementOutputs& y = alone.elements[0];
    CHECK(x.voxel.count() == y.voxel.count());
    CHECK(x.pixel.count() == y.pixel.count());
    CHECK(x.voxel.src_ijk == y.voxel.src_ijk);
    CHECK(x.pixel.src == y.pixel.src);
    CHECK(error(x.voxel.means, y.voxel.means) <= 1e-6);
    CHECK(error(x.voxel.colors, y.voxel.colors) <= 1e-6);
    CHECK(error(x.pixel.means, y.pixel.means) <= 1e-6);
    CHECK(error(x.pixel.colors, y.pixel.colors) <= 1e-6);
    const int64_t E = both.sky_tokens.dim(1);
    const nn::CpuTensor token({1, E}, std::vector<float>(both.sky_tokens.data.begin() + b * E, both.sky_tokens.data.begin() + (b + 1) * E));
    CHECK(error(token, alone.sky_tokens) <= 1e-6);
  }
  // The elements differ (the test would not see a leak otherwise).
  CHECK(both.elements[0].voxel.count() != both.elements[1].voxel.count());
}

TEST_CASE("gsm reference: two views give the same voxel Gaussians and sky token in either order") {
  const std::string dir = test::gsm_small_dir();
  if (dir.empty()) return;
  const nn::GsmConfig c = nn::read_gsm_config(dir + "config.json");
  const nn::GsmWeights w = nn::load_gsm_weights(dir + "weights.safetensors");
  const nn::GsmInputs one = nn::read_gsm_inputs(dir + "inputs");
  const nn::GsmOutputs ab = nn::gsm_forward_reference(c, w, with_second_view(one, false), nullptr);
  const nn::GsmOutputs ba = nn::gsm_forward_reference(c, w, with_second_view(one, true), nullptr);
  const nn::GsmOutputs single = nn::gsm_forward_reference(c, w, one, nullptr);
  const nn::VoxelGaussians &x = ab.elements[0].voxel, &y = ba.elements[0].voxel;
  REQUIRE(x.count() == y.count());
  CHECK(x.count() > single.elements[0].voxel.count());  // the second view sees voxels the first does not
  CHECK(x.src_ijk == y.src_ijk);
  CHECK(x.src_level == y.src_level);
  for (const auto& [name, p, q] : {std::tuple{"means", &x.means, &y.means}, {"scales", &x.scales, &y.scales},
                                   {"rotations", &x.rotations, &y.rotations}, {"opacities", &x.opacities, &y.opacities},
                                   {"colors", &x.colors, &y.colors}}) {
    CAPTURE(name);
    CHECK(error(*p, *q) <= 1e-5);
  }
  CHECK(error(ab.sky_tokens, ba.sky_tokens) <= 1e-5);
  // Pixel Gaussians: the same set with the views swapped.
  const nn::PixelGaussians &pa = ab.elements[0].pixel, &pb = ba.elements[0].pixel;
  REQUIRE(pa.count() == pb.count());
  std::map<std::tuple<int32_t, int32_t, int32_t, int32_t>, int64_t> row_of;
  for (int64_t i = 0; i < pb.count(); ++i)
    row_of[{1 - pb.src[static_cast<size_t>(4 * i)], pb.src[static_cast<size_t>(4 * i + 1)], pb.src[static_cast<size_t>(4 * i + 2)],
            pb.src[static_cast<size_t>(4 * i + 3)]}] = i;
  nn::CpuTensor permuted = pa.means;
  for (int64_t i = 0; i < pa.count(); ++i) {
    const auto it = row_of.find({pa.src[static_cast<size_t>(4 * i)], pa.src[static_cast<size_t>(4 * i + 1)], pa.src[static_cast<size_t>(4 * i + 2)],
                                 pa.src[static_cast<size_t>(4 * i + 3)]});
    REQUIRE(it != row_of.end());
    for (int k = 0; k < 3; ++k)
      permuted.data[static_cast<size_t>(3 * i + k)] = pb.means.data[static_cast<size_t>(3 * it->second + k)];
  }
  CHECK(error(permuted, pa.means) <= 1e-5);
}

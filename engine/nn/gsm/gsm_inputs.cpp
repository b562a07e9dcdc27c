// Reading a GSM case folder; see gsm_inputs.h.
#include "nn/gsm/gsm_inputs.h"

#include "scene/input_error.h"
#include "world/npy.h"

#include <filesystem>

namespace icube::nn {

namespace {

std::string shape_of(const world::NpyArray& a) {
  std::vector<int64_t> s(a.shape.begin(), a.shape.end());
  return shape_text(s);
}

world::NpyArray read_checked(const std::string& path, world::NpyDtype dtype, const std::vector<int64_t>& shape) {
  if (!std::filesystem::exists(path)) throw scene::InputError(path, "", "missing (a GSM case folder needs it)");
  world::NpyArray a = world::read_npy(path);
  if (a.dtype != dtype)
    throw scene::InputError(path, "", std::string("dtype ") + world::npy_dtype_descr(a.dtype) + ", expected " +
                                          world::npy_dtype_descr(dtype));
  bool ok = a.shape.size() == shape.size();
  for (size_t i = 0; ok && i < shape.size(); ++i) ok = shape[i] < 0 || static_cast<int64_t>(a.shape[i]) == shape[i];
  if (!ok) {
    std::string want = "[";
    for (size_t i = 0; i < shape.size(); ++i) want += (i ? ", " : "") + (shape[i] < 0 ? std::string("*") : std::to_string(shape[i]));
    throw scene::InputError(path, "", "shape " + shape_of(a) + ", expected " + want + "]");
  }
  return a;
}

}  // namespace

GsmInputs read_gsm_inputs(const std::string& dir) {
  const std::string d = dir.empty() || dir.back() == '/' ? dir : dir + "/";
  GsmInputs in;
  const world::NpyArray images = read_checked(d + "images.npy", world::NpyDtype::F4, {-1, -1, -1, -1, 3});
  in.batch = static_cast<int64_t>(images.shape[0]);
  in.views = static_cast<int64_t>(images.shape[1]);
  in.height = static_cast<int64_t>(images.shape[2]);
  in.width = static_cast<int64_t>(images.shape[3]);
  if (in.batch < 1 || in.views < 1 || in.height < 16 || in.width < 16)
    throw scene::InputError(d + "images.npy", "", "shape " + shape_of(images) + ": needs B, N >= 1 and H, W >= 16");
  if (in.height % 16 || in.width % 16)
    throw scene::InputError(d + "images.npy", "", "H and W must be multiples of 16 (the sky and depth patches), not " +
                                                      std::to_string(in.height) + " x " + std::to_string(in.width));
  const int64_t B = in.batch, N = in.views, H = in.height, W = in.width;
  in.images = CpuTensor({B, N, H, W, 3}, images.values<float>());
  in.masks = read_checked(d + "masks.npy", world::NpyDtype::U1, {B, N, H, W, 4}).values<uint8_t>();
  const std::vector<float> poses = read_checked(d + "poses.npy", world::NpyDtype::F4, {B, N, 4, 4}).values<float>();
  const std::vector<float> intr = read_checked(d + "intrinsics.npy", world::NpyDtype::F4, {B, N, 6}).values<float>();
  for (int64_t v = 0; v < B * N; ++v) {
    std::array<float, 16> p;
    std::array<float, 6> k;
    for (int i = 0; i < 16; ++i) p[static_cast<size_t>(i)] = poses[static_cast<size_t>(v * 16 + i)];
    for (int i = 0; i < 6; ++i) k[static_cast<size_t>(i)] = intr[static_cast<size_t>(v * 6 + i)];
    if (!(k[0] > 0.0f && k[1] > 0.0f))
      throw scene::InputError(d + "intrinsics.npy", "view " + std::to_string(v), "fx and fy must be positive");
    in.poses.push_back(p);
    in.intrinsics.push_back(k);
  }
  in.depth_patch_keep =
      read_checked(d + "depth_patch_keep.npy", world::NpyDtype::U1, {B, N, H / 16, W / 16}).values<uint8_t>();
  for (int64_t b = 0; b < B; ++b) {
    const std::string path = d + "voxel_ijk.b" + std::to_string(b) + ".npy";
    const std::vector<int32_t> v = read_checked(path, world::NpyDtype::I4, {-1, 3}).values<int32_t>();
    std::vector<Ijk> ijk(v.size() / 3);
    for (size_t i = 0; i < ijk.size(); ++i) ijk[i] = {v[3 * i], v[3 * i + 1], v[3 * i + 2]};
    if (ijk.empty()) throw scene::InputError(path, "", "no voxels");
    in.voxel_ijk.push_back(std::move(ijk));
  }
  return in;
}

CpuTensor gsm_images_nchw(const GsmInputs& in) {
  const int64_t V = in.batch * in.views, HW = in.height * in.width;
  CpuTensor out({V, 3, in.height, in.width});
  for (int64_t v = 0; v < V; ++v)
    for (int64_t p = 0; p < HW; ++p)
      for (int64_t c = 0; c < 3; ++c)
        out.data[static_cast<size_t>((v * 3 + c) * HW + p)] = in.images.data[static_cast<size_t>((v * HW + p) * 3 + c)];
  return out;
}

CpuTensor gsm_effective_mask(const GsmInputs& in) {
  CpuTensor out({in.batch, in.views, in.height, in.width});
  for (size_t i = 0; i < out.data.size(); ++i) out.data[i] = in.masks[4 * i + 1] && in.masks[4 * i + 2] ? 1.0f : 0.0f;
  return out;
}

}  // namespace icube::nn

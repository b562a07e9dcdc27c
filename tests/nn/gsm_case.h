// The official gsm_small reference case (../shared/data/models/gsm_small, see
// its README): its weights, its tensors by name (intermediates and outputs,
// integers as exact floats) and the agreement check every GSM test uses —
// same shape, max |got - ref| / std(ref) <= 1e-4 (exact equality for integer
// tensors). Shared by the GSM stage tests (tests/nn/test_gsm_*.cpp).
#pragma once

#include "gpu_test_context.h"
#include "kernels/nn/cpu_tensor.h"
#include "nn/gsm/gsm_inputs.h"
#include "nn/gsm/gsm_reference.h"
#include "nn/gsm/gsm_weights.h"
#include "nn/safetensors.h"

#include <doctest/doctest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

namespace icube::test {

// The case folder with a trailing slash, or empty (the caller returns; test_data_file reports the skip).
inline std::string gsm_small_dir() {
  const std::string f = test_data_file("models/gsm_small/weights.safetensors");
  return f.empty() ? std::string() : f.substr(0, f.size() - std::string("weights.safetensors").size());
}

// A safetensors file of reference tensors (intermediates.safetensors or outputs.safetensors), read by name.
class GsmTensors {
 public:
  explicit GsmTensors(const std::string& path) : file_(path) {}
  bool has(const std::string& name) const { return file_.find(name) != nullptr; }
  nn::CpuTensor get(const std::string& name) const {
    const nn::TensorInfo* t = file_.find(name);
    REQUIRE_MESSAGE(t != nullptr, "the reference has no tensor " << name);
    return nn::CpuTensor(t->shape, file_.to_f32(*t));
  }
  bool is_integer(const std::string& name) const { return !nn::dtype_is_float(file_.find(name)->dtype); }

 private:
  nn::SafetensorsFile file_;
};

// Checks `got` against the reference tensor `name`: shape, then exact values (integers) or
// max |got - ref| / std(ref) <= tol. Prints the error either way, so a run shows every stage's margin.
inline bool check_gsm_tensor(const GsmTensors& ref, const std::string& name, const nn::CpuTensor& got, double tol = 1e-4) {
  const nn::CpuTensor want = ref.get(name);
  if (got.shape != want.shape) {
    std::printf("  %-44s shape %s, the reference has %s\n", name.c_str(), got.shape_text().c_str(), want.shape_text().c_str());
    CHECK_MESSAGE(false, name << ": shape " << got.shape_text() << " != " << want.shape_text());
    return false;
  }
  if (ref.is_integer(name)) {
    const bool ok = equal_report(got.data, want.data, name.c_str());
    std::printf("  %-44s %s\n", name.c_str(), ok ? "equal" : "DIFFERS");
    CHECK_MESSAGE(ok, name << ": integer values differ");
    return ok;
  }
  const double e = nn::cpu::max_abs_over_std(got.data, want.data);
  std::printf("  %-44s %.3g of std\n", name.c_str(), e);
  CHECK_MESSAGE(e <= tol, name << ": max |got - ref| / std(ref) = " << e << " > " << tol);
  return e <= tol;
}

// A batch of two elements of two views made from the case's inputs: the case's view and its mirror (a
// camera yawed by 0.07 rad, the depth-patch mask inverted), the second element darkened and with every
// other voxel.
inline nn::GsmInputs gsm_two_view_batch(const std::string& dir) {
  const nn::GsmInputs one = nn::read_gsm_inputs(dir + "inputs");
  nn::GsmInputs in = one;
  const int64_t H = one.height, W = one.width;
  in.batch = 2;
  in.views = 2;
  std::vector<float> img;
  std::vector<uint8_t> masks, keep;
  for (int e = 0; e < 2; ++e)
    for (int v = 0; v < 2; ++v) {
      for (int64_t r = 0; r < H; ++r)
        for (int64_t c = 0; c < W; ++c) {
          const int64_t sc = v ? W - 1 - c : c;
          for (int k = 0; k < 3; ++k) img.push_back((e ? 0.6f : 1.0f) * one.images.data[static_cast<size_t>((r * W + sc) * 3 + k)]);
          for (int k = 0; k < 4; ++k) masks.push_back(one.masks[static_cast<size_t>((r * W + sc) * 4 + k)]);
        }
      for (uint8_t k : one.depth_patch_keep) keep.push_back(static_cast<uint8_t>(v ? 1 - k : k));
    }
  in.images = nn::CpuTensor({2, 2, H, W, 3}, img);
  in.masks = masks;
  in.depth_patch_keep = keep;
  std::array<float, 16> yawed = one.poses[0];
  const float ca = std::cos(0.07f), sa = std::sin(0.07f);
  for (int col = 0; col < 3; ++col) {
    const float x = yawed[static_cast<size_t>(col)], y = yawed[static_cast<size_t>(4 + col)];
    yawed[static_cast<size_t>(col)] = ca * x - sa * y;
    yawed[static_cast<size_t>(4 + col)] = sa * x + ca * y;
  }
  in.poses = {one.poses[0], yawed, one.poses[0], yawed};
  in.intrinsics = {one.intrinsics[0], one.intrinsics[0], one.intrinsics[0], one.intrinsics[0]};
  std::vector<nn::Ijk> half;
  for (size_t i = 0; i < one.voxel_ijk[0].size(); i += 2) half.push_back(one.voxel_ijk[0][i]);
  in.voxel_ijk = {one.voxel_ijk[0], half};
  return in;
}

// Every pair of same-named output tensors of two forwards (integers exactly, floats within tol of the
// reference's std), each float tensor's figure printed.
inline void check_gsm_outputs(const nn::GsmOutputs& got, const nn::GsmOutputs& want, double tol) {
  const std::vector<nn::TensorToWrite> g = nn::gsm_output_tensors(got), w = nn::gsm_output_tensors(want);
  REQUIRE(g.size() == w.size());
  for (size_t i = 0; i < g.size(); ++i) {
    CAPTURE(g[i].name);
    REQUIRE(g[i].name == w[i].name);
    REQUIRE(g[i].shape == w[i].shape);
    if (g[i].dtype != nn::DType::F32) {
      CHECK(g[i].bytes == w[i].bytes);
      continue;
    }
    std::vector<float> a(g[i].bytes.size() / 4), b(w[i].bytes.size() / 4);
    std::memcpy(a.data(), g[i].bytes.data(), g[i].bytes.size());
    std::memcpy(b.data(), w[i].bytes.data(), w[i].bytes.size());
    if (a.empty()) continue;
    const double e = nn::cpu::max_abs_over_std(a, b);
    std::printf("  %-30s %.3g of std against the CPU reference\n", g[i].name.c_str(), e);
    CHECK(e <= tol);
  }
}

}  // namespace icube::test

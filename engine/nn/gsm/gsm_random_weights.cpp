// Seeded random GSM weights; see gsm_random_weights.h.
#include "nn/gsm/gsm_random_weights.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>
#include <stdexcept>

namespace icube::nn {

namespace {

constexpr int64_t kQuaternionW = 6;       // voxel heads: xyz 0..2, log-scale 3..5, quaternion 6..9, opacity 10, colour 11..
constexpr int64_t kPixelQuaternionW = 4;  // pixel branch: depth 0, scale 1..3, quaternion 4..7, opacity 8, colour 9..

void fill_uniform(CpuTensor& t, std::mt19937& rng, int64_t fan_in) {
  const float bound = 1.0f / std::sqrt(static_cast<float>(std::max<int64_t>(1, fan_in)));
  std::uniform_real_distribution<float> u(-bound, bound);
  for (float& v : t.data) v = u(rng);
}

void fill_normal(CpuTensor& t, std::mt19937& rng, float mean, float std) {
  std::normal_distribution<float> n(0.0f, 1.0f);
  for (float& v : t.data) v = mean + std * n(rng);
}

// Pure3DUnet's apply_gs_init on a [gaussians * gs_dim] bias (gs_init_scale 0.5).
void voxel_gaussian_bias(CpuTensor& t, std::mt19937& rng, int64_t fan_in, int64_t gs_dim) {
  fill_uniform(t, rng, fan_in);  // what construction left in the entries the pattern does not set
  const int64_t gaussians = t.numel() / gs_dim;
  std::normal_distribution<float> n(0.0f, 1.0f);
  for (int64_t g = 0; g < gaussians; ++g) {
    float* b = t.data.data() + g * gs_dim;
    for (int i = 0; i < 3; ++i) b[i] = gaussians > 1 ? 0.5f * n(rng) : 0.0f;
    for (int i = 3; i < 6; ++i) b[i] = std::log(0.5f);
    b[kQuaternionW] = 1.0f;
    for (int i = 7; i < 10; ++i) b[i] = 0.0f;
    b[10] = std::log(0.1f / 0.9f);
    if (gs_dim == 14)
      for (int i = 11; i < 14; ++i) b[i] = 0.5f;
  }
}

}  // namespace

GsmWeights gsm_random_weights(const std::vector<GsmParamSpec>& specs, uint32_t seed) {
  std::mt19937 rng(seed);
  GsmWeights w;
  w.source = "random weights (seed " + std::to_string(seed) + ")";
  for (const GsmParamSpec& s : specs) {
    CpuTensor t(s.shape);
    switch (s.role) {
      case GsmTensorRole::Weight:
      case GsmTensorRole::Bias: fill_uniform(t, rng, s.fan_in); break;
      case GsmTensorRole::NormWeight: fill_normal(t, rng, 1.0f, 0.1f); break;
      case GsmTensorRole::NormBias: fill_normal(t, rng, 0.0f, 0.1f); break;
      case GsmTensorRole::Token: fill_normal(t, rng, 0.0f, 0.5f); break;
      case GsmTensorRole::Query: fill_normal(t, rng, 0.0f, 1.0f); break;
      case GsmTensorRole::RunningMean: fill_normal(t, rng, 0.0f, 0.1f); break;
      case GsmTensorRole::RunningVar: {
        std::uniform_real_distribution<float> u(0.5f, 1.5f);
        for (float& v : t.data) v = u(rng);
        break;
      }
      case GsmTensorRole::BatchCount: break;  // 0
      case GsmTensorRole::VoxelGaussianBias:
        if (s.group < 11 || t.numel() % s.group) throw std::invalid_argument("gsm random weights: " + s.name + " is not whole Gaussians");
        voxel_gaussian_bias(t, rng, s.fan_in, s.group);
        break;
      case GsmTensorRole::PixelGaussianBias:
        if (s.group < 9 || t.numel() % s.group) throw std::invalid_argument("gsm random weights: " + s.name + " is not whole Gaussians");
        fill_uniform(t, rng, s.fan_in);
        for (int64_t g = 0; g < t.numel() / s.group; ++g) t.data[static_cast<size_t>(g * s.group + kPixelQuaternionW)] += 1.0f;
        break;
    }
    w.tensors.emplace(s.name, std::move(t));
  }
  return w;
}

std::vector<TensorToWrite> gsm_weight_file_tensors(GsmWeights&& weights, const std::vector<GsmParamSpec>& specs) {
  std::vector<TensorToWrite> out;
  out.reserve(specs.size());
  for (const GsmParamSpec& s : specs) {
    auto it = weights.tensors.find(s.name);
    if (it == weights.tensors.end()) throw std::invalid_argument("gsm weights: no tensor " + s.name);
    if (s.integer()) {
      TensorToWrite t;
      t.name = s.name;
      t.dtype = DType::I64;
      t.shape = s.shape;
      t.bytes.resize(it->second.data.size() * sizeof(int64_t));
      for (size_t i = 0; i < it->second.data.size(); ++i) {
        const int64_t v = static_cast<int64_t>(it->second.data[i]);
        std::memcpy(t.bytes.data() + i * sizeof(int64_t), &v, sizeof v);  // little-endian hosts (as the reader)
      }
      out.push_back(std::move(t));
    } else {
      out.push_back(f32_tensor(s.name, s.shape, it->second.data));
    }
    weights.tensors.erase(it);
  }
  return out;
}

}  // namespace icube::nn

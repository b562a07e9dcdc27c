// CPU reference of the structure VAE; see vae_reference.h.
#include "nn/vae_reference.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace icube::nn {

std::vector<float> position_embedding(const std::array<float, 3>& p, int freqs) {
  std::vector<float> out(p.begin(), p.end());
  for (int f = 0; f < freqs; ++f) {
    const float scale = static_cast<float>(1 << f);
    for (int fn = 0; fn < 2; ++fn)
      for (int d = 0; d < 3; ++d) {
        const float x = p[static_cast<size_t>(d)] * scale;  // float32 product, as torch
        out.push_back(static_cast<float>(fn == 0 ? std::sin(double{x}) : std::cos(double{x})));
      }
  }
  return out;
}

VaeReference::VaeReference(const VaeConfig& config, std::map<std::string, CpuTensor> weights)
    : config_(config), weights_(std::move(weights)) {}

const CpuTensor& VaeReference::w(const std::string& name) const {
  const auto it = weights_.find(name);
  if (it == weights_.end()) throw std::invalid_argument("VAE reference: no weight '" + name + "'");
  return it->second;
}

const CpuTensor* VaeReference::maybe(const std::string& name) const {
  const auto it = weights_.find(name);
  return it == weights_.end() ? nullptr : &it->second;
}

SparseTensor VaeReference::conv_block(const std::string& name, SparseTensor x) const {
  for (const char op : config_.order) {
    if (op == 'g') {
      const int groups = x.channels < config_.num_groups ? 1 : config_.num_groups;
      x = cpu::group_norm(x, groups, w(name + ".GroupNorm.weight"), w(name + ".GroupNorm.bias"));
    } else if (op == 'c') {
      x = cpu::conv3d(x, w(name + ".Conv.weight"), maybe(name + ".Conv.bias"));
    } else if (op == 's') {
      x = cpu::silu(std::move(x));
    } else if (op == 'r') {
      for (float& v : x.data) v = std::max(v, 0.0f);
    }
  }
  return x;
}

SparseTensor VaeReference::res_block(const std::string& name, SparseTensor x) const {
  SparseTensor h = conv_block(name + ".conv2", conv_block(name + ".conv1", x));
  if (const CpuTensor* skip = maybe(name + ".skip_connection.weight"))
    x = cpu::linear(x, *skip, &w(name + ".skip_connection.bias"));
  return cpu::add(std::move(h), x);
}

SparseTensor VaeReference::head(const std::string& name, const SparseTensor& x) const {
  return cpu::linear(conv_block(name + ".SingleConv", x), w(name + ".OutConv.weight"), &w(name + ".OutConv.bias"));
}

VaeDecoded VaeReference::decode(const SparseTensor& latent) const {
  const int nb = config_.num_blocks;
  if (latent.channels != config_.latent_channels())
    throw std::invalid_argument("VAE decode: latent has " + std::to_string(latent.channels) + " channels, the model " +
                                std::to_string(config_.latent_channels()));
  SparseTensor x = res_block("unet.post_kl_bottleneck.post_kl_bottleneck_0", latent);
  x = res_block("unet.post_kl_bottleneck.post_kl_bottleneck_1", std::move(x));
  VaeDecoded out;
  out.levels.resize(static_cast<size_t>(nb));
  std::vector<uint8_t> keep;
  for (int depth = nb - 1; depth >= 0; --depth) {
    const std::string idx = std::to_string(depth - nb);  // -1 at the latent level
    if (depth < nb - 1) {
      x = cpu::subdivide(x, keep, config_.subdivide_factor(depth));
      for (int b = 0; b <= config_.num_res_blocks; ++b)
        x = res_block("unet.decoders.Dec" + idx + "." + std::to_string(b), std::move(x));
    }
    SparseTensor logits = x.rows() > 0 ? head("unet.struct_convs.Struct" + idx, x) : SparseTensor{x.grid, 2, {}};
    keep.assign(static_cast<size_t>(x.rows()), 0);
    int64_t kept = 0;
    for (int64_t r = 0; r < x.rows(); ++r) {
      keep[static_cast<size_t>(r)] = logits.row(r)[0] > logits.row(r)[1] ? 1 : 0;
      kept += keep[static_cast<size_t>(r)];
    }
    out.levels[static_cast<size_t>(depth)] = {x.grid, logits.data};
    if (kept == 0 && out.warning.empty())
      out.warning = "the structure head at depth " + std::to_string(depth) + " kept no voxel: the chunk decodes empty";
  }
  x = cpu::subdivide(x, keep, {1, 1, 1});
  if (x.rows() == 0) {
    out.semantic.grid = x.grid;
    out.semantic.channels = config_.num_semantic_classes;
    return out;
  }
  out.semantic = head("unet.semantic_head", x);
  return out;
}

SparseTensor VaeReference::input_features(const SparseGrid& grid, const std::vector<int32_t>& classes) const {
  if (static_cast<int64_t>(classes.size()) != grid.size())
    throw std::invalid_argument("VAE encode: " + std::to_string(classes.size()) + " classes for " +
                                std::to_string(grid.size()) + " voxels");
  const CpuTensor& embed = w("encoder.semantic_embed_fn.weight");
  SparseTensor f;
  f.grid = grid;
  f.channels = config_.encoder_input_dim();
  f.data.reserve(static_cast<size_t>(grid.size() * f.channels));
  for (int64_t r = 0; r < grid.size(); ++r) {
    std::array<float, 3> p{};
    for (int d = 0; d < 3; ++d)
      p[static_cast<size_t>(d)] = static_cast<float>(grid.ijk[static_cast<size_t>(r)][static_cast<size_t>(d)]) *
                                      static_cast<float>(grid.voxel_size[static_cast<size_t>(d)]) +
                                  static_cast<float>(grid.origin[static_cast<size_t>(d)]);
    const std::vector<float> pe = position_embedding(p, config_.pos_freqs);
    f.data.insert(f.data.end(), pe.begin(), pe.end());
    const int32_t c = classes[static_cast<size_t>(r)];
    if (c < 0 || c >= config_.num_semantic)
      throw std::invalid_argument("VAE encode: class " + std::to_string(c) + " at row " + std::to_string(r) +
                                  " is outside [0, " + std::to_string(config_.num_semantic) + ")");
    const float* e = embed.data.data() + int64_t{c} * config_.dim_semantic;
    f.data.insert(f.data.end(), e, e + config_.dim_semantic);
  }
  return cpu::linear(f, w("encoder.mix_fc.weight"), &w("encoder.mix_fc.bias"));
}

SparseTensor VaeReference::encode(const SparseGrid& grid, const std::vector<int32_t>& classes) const {
  const int nb = config_.num_blocks;
  SparseTensor x = cpu::linear(input_features(grid, classes), w("unet.pre_conv.weight"), &w("unet.pre_conv.bias"));
  for (int l = 0; l < nb; ++l)
    for (int b = 0; b < config_.num_res_blocks; ++b) {
      if (l > 0 && b == 0) x = cpu::max_pool(x, config_.pool_factor(l));
      x = res_block("unet.encoders.Enc" + std::to_string(l) + "-Block" + std::to_string(b), std::move(x));
    }
  if (config_.neck_dense) {
    const Ijk& b = config_.neck_bound;
    const SparseGrid box = dense_box_grid({-b[0], -b[1], -b[2]}, {2 * b[0], 2 * b[1], 2 * b[2]}, x.grid.voxel_size, x.grid.origin);
    const std::vector<int32_t> rows = cpu::find_rows(x.grid, box.ijk);
    SparseTensor dense;
    dense.grid = box;
    dense.channels = x.channels;
    dense.data.assign(static_cast<size_t>(box.size() * x.channels), 0.0f);
    for (int64_t r = 0; r < box.size(); ++r)
      if (rows[static_cast<size_t>(r)] >= 0) std::copy_n(x.row(rows[static_cast<size_t>(r)]), x.channels, dense.row(r));
    x = std::move(dense);
  }
  x = res_block("unet.pre_kl_bottleneck.pre_kl_bottleneck_0", std::move(x));
  x = res_block("unet.pre_kl_bottleneck.pre_kl_bottleneck_1", std::move(x));
  const int groups = x.channels < config_.num_groups ? 1 : config_.num_groups;
  x = cpu::group_norm(x, groups, w("unet.pre_kl_bottleneck.pre_kl_bottleneck_gn.module.weight"),
                      w("unet.pre_kl_bottleneck.pre_kl_bottleneck_gn.module.bias"));
  x = cpu::conv3d(x, w("unet.pre_kl_bottleneck.pre_kl_bottleneck_2.module.weight"),
                  &w("unet.pre_kl_bottleneck.pre_kl_bottleneck_2.module.bias"));
  SparseTensor mu;
  mu.grid = x.grid;
  mu.channels = config_.latent_channels();
  for (int64_t r = 0; r < x.rows(); ++r) mu.data.insert(mu.data.end(), x.row(r), x.row(r) + mu.channels);
  return mu;
}

}  // namespace icube::nn

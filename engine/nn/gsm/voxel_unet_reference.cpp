// The GSM voxel branch's lifter and sparse U-Net on the CPU; see voxel_unet_reference.h.
#include "nn/gsm/voxel_unet_reference.h"

#include "kernels/nn/scatter_mean.h"

#include "kernels/nn/conv3d.h"
#include "nn/gsm/gsm_json.h"
#include "nn/vae_weights.h"
#include "scene/input_error.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <stdexcept>
#include <string>
#include <utility>

namespace icube::nn {

namespace {

const std::string kPrefix = "backbone.backbone_3d.";
const std::string kParams = "backbone.params.backbone_3d_params";

std::string batch_name(const std::string& name, int b) { return b == 0 ? name : name + ".b" + std::to_string(b); }

bool ijk_less(const Ijk& a, const Ijk& b) { return a < b; }

CpuTensor ijk_tensor(const SparseGrid& g) {
  CpuTensor t({g.size(), 3});
  for (int64_t r = 0; r < g.size(); ++r)
    for (int a = 0; a < 3; ++a) t.data[static_cast<size_t>(r * 3 + a)] = static_cast<float>(g.ijk[static_cast<size_t>(r)][a]);
  return t;
}

CpuTensor features_tensor(const SparseTensor& x) { return CpuTensor({x.rows(), x.channels}, x.data); }

void trace_sparse(GsmTrace* trace, const std::string& name, const SparseTensor& x) {
  if (!trace) return;
  trace_put(trace, name, features_tensor(x));
  trace_put(trace, name + ".ijk", ijk_tensor(x.grid));
}

SparseTensor sparse_zeros(const SparseGrid& g, int64_t channels) {
  SparseTensor t;
  t.grid = g;
  t.channels = channels;
  t.data.assign(static_cast<size_t>(g.size() * channels), 0.0f);
  return t;
}

// 2x2x2 max pooling of `fine` onto the given coarse grid: each coarse voxel is the maximum of its existing
// children (fVDB MaxPool with a reference grid); a coarse voxel without children is 0.
SparseTensor max_pool_onto(const SparseTensor& fine, const SparseGrid& coarse) {
  std::vector<Ijk> children;
  children.reserve(static_cast<size_t>(coarse.size() * 8));
  for (const Ijk& c : coarse.ijk)
    for (int32_t i = 0; i < 2; ++i)
      for (int32_t j = 0; j < 2; ++j)
        for (int32_t k = 0; k < 2; ++k) children.push_back({2 * c[0] + i, 2 * c[1] + j, 2 * c[2] + k});
  const std::vector<int32_t> rows = cpu::find_rows(fine.grid, children);
  SparseTensor y = sparse_zeros(coarse, fine.channels);
  for (int64_t r = 0; r < coarse.size(); ++r) {
    float* out = y.row(r);
    bool any = false;
    for (int q = 0; q < 8; ++q) {
      const int32_t src = rows[static_cast<size_t>(r * 8 + q)];
      if (src < 0) continue;
      const float* in = fine.row(src);
      for (int64_t ch = 0; ch < fine.channels; ++ch) out[ch] = any ? std::max(out[ch], in[ch]) : in[ch];
      any = true;
    }
  }
  return y;
}

// The rows with keep[r] set, each split into its 2x2x2 children with the parent's features (fVDB
// UpsamplingNearest(2) with a mask); children in lexicographic order.
SparseTensor subdivide_kept(const SparseTensor& x, const std::vector<uint8_t>& keep) {
  std::vector<std::pair<Ijk, int64_t>> children;
  for (int64_t r = 0; r < x.rows(); ++r) {
    if (!keep[static_cast<size_t>(r)]) continue;
    const Ijk& c = x.grid.ijk[static_cast<size_t>(r)];
    for (int32_t i = 0; i < 2; ++i)
      for (int32_t j = 0; j < 2; ++j)
        for (int32_t k = 0; k < 2; ++k) children.push_back({{2 * c[0] + i, 2 * c[1] + j, 2 * c[2] + k}, r});
  }
  std::sort(children.begin(), children.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  SparseGrid g;
  for (int a = 0; a < 3; ++a) {
    g.voxel_size[a] = x.grid.voxel_size[a] / 2;
    g.origin[a] = x.grid.origin[a] - g.voxel_size[a] / 2;
  }
  for (const auto& ch : children) g.ijk.push_back(ch.first);
  SparseTensor y = sparse_zeros(g, x.channels);
  for (size_t r = 0; r < children.size(); ++r)
    std::copy(x.row(children[r].second), x.row(children[r].second) + x.channels, y.row(static_cast<int64_t>(r)));
  return y;
}

// The features of `src` at the voxels of `target` (0 where src has none): fVDB FillFromGrid.
SparseTensor fill_from(const SparseTensor& src, const SparseGrid& target) {
  const std::vector<int32_t> rows = cpu::find_rows(src.grid, target.ijk);
  SparseTensor y = sparse_zeros(target, src.channels);
  for (int64_t r = 0; r < target.size(); ++r) {
    const int32_t s = rows[static_cast<size_t>(r)];
    if (s >= 0) std::copy(src.row(s), src.row(s) + src.channels, y.row(r));
  }
  return y;
}

// [a | b] per row; same grid.
SparseTensor concat(const SparseTensor& a, const SparseTensor& b) {
  SparseTensor y = sparse_zeros(a.grid, a.channels + b.channels);
  for (int64_t r = 0; r < a.rows(); ++r) {
    std::copy(a.row(r), a.row(r) + a.channels, y.row(r));
    std::copy(b.row(r), b.row(r) + b.channels, y.row(r) + a.channels);
  }
  return y;
}

// 1 where the voxel of `grid` is in `tree_level`.
std::vector<uint8_t> membership(const SparseGrid& grid, const SparseGrid& tree_level) {
  const std::vector<int32_t> rows = cpu::find_rows(tree_level, grid.ijk);
  std::vector<uint8_t> in(rows.size());
  for (size_t r = 0; r < rows.size(); ++r) in[r] = rows[r] >= 0 ? 1 : 0;
  return in;
}

class UnetRunner {
 public:
  UnetRunner(const VoxelUnetConfig& c, const GsmWeights& w) : c_(c), w_(w) {}

  // GroupNorm -> 3x3x3 submanifold conv (no bias) -> SiLU.
  SparseTensor conv_block(const std::string& p, const SparseTensor& x, int64_t out) const {
    const int64_t in = x.channels;
    const int groups = in < c_.num_groups ? 1 : c_.num_groups;
    SparseTensor h = cpu::group_norm(x, groups, w_.at(p + "GroupNorm.weight", {in}), w_.at(p + "GroupNorm.bias", {in}), 1e-5);
    h = cpu::conv3d(h, fvdb020_kernel_to_grid_order(w_.at(p + "Conv.weight", {out, in, 3, 3, 3})), nullptr);
    return cpu::silu(std::move(h));
  }

  // SparseResBlock: encoder blocks widen in conv2, decoder and bottleneck blocks in conv1.
  SparseTensor res_block(const std::string& p, const SparseTensor& x, int64_t out, bool encoder) const {
    const int64_t in = x.channels;
    const int64_t mid = encoder ? std::max(out / 2, in) : out;
    SparseTensor h = conv_block(p + "conv1.", x, mid);
    h = conv_block(p + "conv2.", h, out);
    if (in == out) return cpu::add(std::move(h), x);
    const SparseTensor skip =
        cpu::linear(x, w_.at(p + "skip_connection.weight", {out, in}), &w_.at(p + "skip_connection.bias", {out}));
    return cpu::add(std::move(h), skip);
  }

 private:
  const VoxelUnetConfig& c_;
  const GsmWeights& w_;
};

}  // namespace

std::vector<int> VoxelUnetConfig::widths() const {
  std::vector<int> n{in_channels};
  for (int d = 0; d < num_blocks; ++d) n.push_back(f_maps << d);
  return n;
}

VoxelUnetConfig voxel_unet_config_from_json(const nlohmann::json& hparams) {
  const nlohmann::json& p = gsm_json::at(hparams, kParams);
  auto refuse_unless = [&](bool ok, const std::string& key, const std::string& what) {
    if (!ok) throw scene::InputError("the GSM config", kParams + "." + key, what);
  };
  if (gsm_json::has(hparams, "backbone.params.backbone_3d_target"))
    if (gsm_json::text(hparams, "backbone.params.backbone_3d_target") != "Pure3DUnet")
      throw scene::InputError("the GSM config", "backbone.params.backbone_3d_target",
                              "only Pure3DUnet is implemented");
  VoxelUnetConfig c;
  c.image_channels = gsm_json::integer(p, "lifter_params.img_in_dim", "the GSM config: " + kParams);
  const int lifter_out = gsm_json::integer(p, "lifter_params.voxel_out_dim", "the GSM config: " + kParams);
  c.in_channels = gsm_json::integer(p, "in_channels", "the GSM config: " + kParams);
  c.num_blocks = gsm_json::integer(p, "num_blocks", "the GSM config: " + kParams);
  c.f_maps = p.contains("f_maps") ? gsm_json::integer(p, "f_maps", "the GSM config: " + kParams) : 64;
  c.num_groups = p.contains("num_groups") ? gsm_json::integer(p, "num_groups", "the GSM config: " + kParams) : 8;
  refuse_unless(lifter_out == c.in_channels, "lifter_params.voxel_out_dim", "must equal in_channels");
  refuse_unless(c.image_channels > 0 && c.in_channels > 0 && c.f_maps > 0, "in_channels",
                "widths must be positive");
  refuse_unless(c.num_blocks >= 1 && c.num_blocks <= 8, "num_blocks", "must be 1 .. 8");
  refuse_unless(c.num_groups >= 1, "num_groups", "must be positive");
  refuse_unless(!p.contains("order") || gsm_json::text(p, "order") == "gcs", "order",
                "only \"gcs\" (GroupNorm, conv, SiLU) is implemented");
  refuse_unless(!p.contains("neck_dense_type") || gsm_json::text(p, "neck_dense_type") == "UNCHANGED",
                "neck_dense_type", "only UNCHANGED is implemented");
  refuse_unless(!p.contains("use_attention") || !gsm_json::boolean(p, "use_attention"), "use_attention",
                "attention blocks are not implemented");
  refuse_unless(!p.contains("use_residual") || gsm_json::boolean(p, "use_residual"), "use_residual",
                "only residual blocks are implemented");
  return c;
}

CpuTensor voxel_lifter_forward(const VoxelUnetConfig& c, const GsmWeights& w, const CpuTensor& image_features,
                               const std::vector<int32_t>& first_voxel, const CpuTensor& effective_mask, int64_t voxels,
                               int batch_index, GsmTrace* trace) {
  if (image_features.rank() != 4 || image_features.dim(1) != c.image_channels)
    throw std::invalid_argument("voxel lifter: image features " + image_features.shape_text() + ", expected " +
                                std::to_string(c.image_channels) + " channels");
  const CpuTensor mean = cpu::scatter_mean(image_features, first_voxel, effective_mask, voxels);
  trace_put(trace, batch_name("vox.lifter.in", batch_index), mean);
  const CpuTensor& fc_w = w.at(kPrefix + "lifter.mix_fc.weight", {c.in_channels, c.image_channels});
  const CpuTensor& fc_b = w.at(kPrefix + "lifter.mix_fc.bias", {c.in_channels});
  CpuTensor lifted = cpu::linear(mean, fc_w, &fc_b);
  trace_put(trace, batch_name("vox.lifter", batch_index), lifted);
  return lifted;
}

CpuTensor voxel_unet_forward(const VoxelUnetConfig& c, const GsmWeights& w, const SparseGrid& grid,
                             const CpuTensor& lifted, int batch_index, GsmTrace* trace) {
  if (lifted.shape != std::vector<int64_t>{grid.size(), c.in_channels})
    throw std::invalid_argument("voxel unet: input " + lifted.shape_text() + " for " + std::to_string(grid.size()) +
                                " voxels of width " + std::to_string(c.in_channels));
  const std::vector<int> width = c.widths();
  const int levels = c.num_blocks;
  const UnetRunner run(c, w);
  auto name = [&](const std::string& n) { return batch_name(n, batch_index); };

  std::vector<SparseGrid> tree{grid};
  for (int d = 1; d < levels; ++d) tree.push_back(gsm_hash_tree_level(grid, d));

  SparseTensor x;
  x.grid = grid;
  x.channels = c.in_channels;
  x.data = lifted.data;
  x = cpu::linear(x, w.at(kPrefix + "pre_conv.weight", {c.in_channels, c.in_channels}),
                  &w.at(kPrefix + "pre_conv.bias", {c.in_channels}));
  trace_put(trace, name("vox.pre_conv"), features_tensor(x));

  std::vector<SparseTensor> encoded;
  for (int d = 0; d < levels; ++d) {
    if (d > 0) x = max_pool_onto(x, tree[static_cast<size_t>(d)]);
    const std::string block = "encoders.Enc" + std::to_string(d);
    x = run.res_block(kPrefix + block + ".", x, width[static_cast<size_t>(d + 1)], true);
    trace_sparse(trace, name("vox." + block + ".0"), x);
    encoded.push_back(x);
  }

  const int64_t deepest = width.back();
  x = run.res_block(kPrefix + "pre_kl_bottleneck.pre_kl_bottleneck_0.", x, deepest, false);
  trace_sparse(trace, name("vox.pre_kl_bottleneck.pre_kl_bottleneck_0.0"), x);
  for (int j = 0; j < 2; ++j) {
    const std::string block = "post_kl_bottleneck.post_kl_bottleneck_" + std::to_string(j);
    x = run.res_block(kPrefix + block + ".", x, deepest, false);
    trace_sparse(trace, name("vox." + block + ".0"), x);
  }

  for (int d = levels - 2; d >= 0; --d) {
    // Subdivide the voxels the tree keeps at the current level, then [encoder features, upsampled] -> block.
    const SparseTensor up = subdivide_kept(x, membership(x.grid, tree[static_cast<size_t>(d + 1)]));
    const SparseTensor skip = fill_from(encoded[static_cast<size_t>(d)], up.grid);
    const std::string block = "decoders.Dec-" + std::to_string(levels - d);
    x = run.res_block(kPrefix + block + ".", concat(skip, up), width[static_cast<size_t>(d + 1)], false);
    trace_sparse(trace, name("vox." + block + ".0"), x);
  }

  // Keep only the input voxels, in the input grid's row order.
  const std::vector<int32_t> rows = cpu::find_rows(x.grid, grid.ijk);
  CpuTensor out({grid.size(), x.channels});
  for (int64_t r = 0; r < grid.size(); ++r) {
    const int32_t s = rows[static_cast<size_t>(r)];
    if (s < 0) throw std::invalid_argument("voxel unet: input voxel " + std::to_string(r) + " missing after decoding");
    std::copy(x.row(s), x.row(s) + x.channels, out.data.begin() + r * x.channels);
  }
  trace_put(trace, "vox.out.b" + std::to_string(batch_index), out);
  trace_put(trace, "vox.out.b" + std::to_string(batch_index) + ".ijk", ijk_tensor(grid));
  return out;
}

VoxelFrontMasks voxel_front_masks(const std::vector<int32_t>& first_voxel, int64_t views, int64_t voxels,
                                  int batch_index, GsmTrace* trace) {
  if (views < 1 || first_voxel.size() % static_cast<size_t>(views) != 0)
    throw std::invalid_argument("voxel front masks: " + std::to_string(first_voxel.size()) + " rows for " +
                                std::to_string(views) + " views");
  const int64_t per_view = static_cast<int64_t>(first_voxel.size()) / views;
  VoxelFrontMasks m;
  m.front.assign(static_cast<size_t>(voxels), 0);
  m.front_per_view.assign(static_cast<size_t>(voxels * views), 0);
  for (int64_t n = 0; n < views; ++n)
    for (int64_t p = 0; p < per_view; ++p) {
      const int32_t row = first_voxel[static_cast<size_t>(n * per_view + p)];
      if (row < 0) continue;
      if (row >= voxels) throw std::invalid_argument("voxel front masks: row " + std::to_string(row) + " of " + std::to_string(voxels));
      m.front[static_cast<size_t>(row)] = 1;
      m.front_per_view[static_cast<size_t>(row * views + n)] = 1;
    }
  if (trace) {
    const std::string b = ".b" + std::to_string(batch_index);
    CpuTensor front({voxels}), per({voxels, views});
    for (size_t i = 0; i < m.front.size(); ++i) front.data[i] = m.front[i];
    for (size_t i = 0; i < m.front_per_view.size(); ++i) per.data[i] = m.front_per_view[i];
    trace_put(trace, "vox.occ_front_mask" + b, front);
    trace_put(trace, "vox.occ_front_per_camera" + b, per);
  }
  return m;
}

VoxelBranchFeatures voxel_branch_features(const VoxelUnetConfig& c, const GsmWeights& w, const SparseGrid& grid,
                                          const CpuTensor& image_features, const std::vector<int32_t>& first_voxel,
                                          const CpuTensor& effective_mask, int batch_index, GsmTrace* trace) {
  VoxelBranchFeatures out;
  const CpuTensor lifted =
      voxel_lifter_forward(c, w, image_features, first_voxel, effective_mask, grid.size(), batch_index, trace);
  out.features = voxel_unet_forward(c, w, grid, lifted, batch_index, trace);
  out.front = voxel_front_masks(first_voxel, image_features.dim(0), grid.size(), batch_index, trace);
  return out;
}

SparseGrid gsm_hash_tree_level(const SparseGrid& input, int d) {
  SparseGrid g;
  const int32_t f = 1 << d;
  for (int a = 0; a < 3; ++a) {
    g.voxel_size[a] = input.voxel_size[a] * f;
    g.origin[a] = input.origin[a] + 0.5 * input.voxel_size[a] * (f - 1);
  }
  g.ijk.reserve(input.ijk.size() * 8);
  for (const Ijk& v : input.ijk) {
    Ijk base;
    for (int a = 0; a < 3; ++a) base[a] = floor_div(2 * v[a] + 1 - f, 2 * f);
    for (int32_t i = 0; i < 2; ++i)
      for (int32_t j = 0; j < 2; ++j)
        for (int32_t k = 0; k < 2; ++k) g.ijk.push_back({base[0] + i, base[1] + j, base[2] + k});
  }
  std::sort(g.ijk.begin(), g.ijk.end(), ijk_less);
  g.ijk.erase(std::unique(g.ijk.begin(), g.ijk.end()), g.ijk.end());
  return g;
}

}  // namespace icube::nn

// The GSM voxel branch's lifter and sparse U-Net on the GPU; see voxel_unet_gpu.h.
#include "nn/gsm/voxel_unet_gpu.h"

#include "kernels/nn/scatter_mean.h"

#include <algorithm>
#include <stdexcept>
#include <string>
#include <utility>

namespace icube::nn {

namespace {

const std::string kPrefix = "backbone.backbone_3d.";

std::string batch_name(const std::string& name, int b) { return b == 0 ? name : name + ".b" + std::to_string(b); }

uint32_t u32(int64_t v) { return static_cast<uint32_t>(v); }

CpuTensor ijk_tensor(const SparseGrid& g) {
  CpuTensor t({g.size(), 3});
  for (int64_t r = 0; r < g.size(); ++r)
    for (int a = 0; a < 3; ++a) t.data[static_cast<size_t>(r * 3 + a)] = static_cast<float>(g.ijk[static_cast<size_t>(r)][static_cast<size_t>(a)]);
  return t;
}

void trace_features(VoxelBranchGpuTrace* trace, const std::string& name, const DeviceTensor& x) {
  if (trace) trace->device[name] = x;
}

void trace_sparse(VoxelBranchGpuTrace* trace, const std::string& name, const DeviceTensor& x, const SparseGrid& g) {
  if (!trace) return;
  trace->device[name] = x;
  trace_put(&trace->host, name + ".ijk", ijk_tensor(g));
}

void require_shape(const LayerRecorder& L, const std::string& name, const std::vector<int64_t>& shape) {
  const std::vector<int64_t>& have = L.params().shape(name);
  if (have != shape)
    throw std::invalid_argument("gsm voxel unet: " + name + " has shape " + shape_text(have) + ", the U-Net needs " + shape_text(shape));
}

// For each voxel of `coarse` the rows of its 2x2x2 children in `fine` (-1 where absent), [coarse rows * 8].
std::vector<int32_t> child_rows(const SparseGrid& fine, const SparseGrid& coarse) {
  std::vector<Ijk> children;
  children.reserve(coarse.ijk.size() * 8);
  for (const Ijk& c : coarse.ijk)
    for (int32_t i = 0; i < 2; ++i)
      for (int32_t j = 0; j < 2; ++j)
        for (int32_t k = 0; k < 2; ++k) children.push_back({2 * c[0] + i, 2 * c[1] + j, 2 * c[2] + k});
  return cpu::find_rows(fine, children);
}

// The children (lexicographic) of the voxels of `grid` that are in `tree_level`, with each child's parent row.
SparseGrid subdivide_members(const SparseGrid& grid, const SparseGrid& tree_level, std::vector<int32_t>& parents) {
  const std::vector<int32_t> member = cpu::find_rows(tree_level, grid.ijk);
  std::vector<std::pair<Ijk, int32_t>> children;
  for (size_t r = 0; r < grid.ijk.size(); ++r) {
    if (member[r] < 0) continue;
    const Ijk& c = grid.ijk[r];
    for (int32_t i = 0; i < 2; ++i)
      for (int32_t j = 0; j < 2; ++j)
        for (int32_t k = 0; k < 2; ++k) children.push_back({{2 * c[0] + i, 2 * c[1] + j, 2 * c[2] + k}, static_cast<int32_t>(r)});
  }
  std::sort(children.begin(), children.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  SparseGrid g;
  for (size_t a = 0; a < 3; ++a) {
    g.voxel_size[a] = grid.voxel_size[a] / 2;
    g.origin[a] = grid.origin[a] - g.voxel_size[a] / 2;
  }
  parents.clear();
  for (const auto& ch : children) {
    g.ijk.push_back(ch.first);
    parents.push_back(ch.second);
  }
  return g;
}

class BlockRecorder {
 public:
  BlockRecorder(LayerRecorder& L, const VoxelUnetConfig& c) : L_(L), c_(c) {}

  // GroupNorm -> 3x3x3 submanifold conv (no bias) with the SiLU fused.
  DeviceTensor conv_block(const std::string& p, const DeviceTensor& x, int64_t out, const gpu::Buffer& kmap) const {
    const int64_t in = x.channels();
    const std::string conv = gsm_sparse_conv_grid_order(p + "Conv");
    require_shape(L_, p + "GroupNorm.weight", {in});
    require_shape(L_, conv + ".weight", {out, in, 3, 3, 3});
    const uint32_t groups = in < c_.num_groups ? 1u : static_cast<uint32_t>(c_.num_groups);
    const DeviceTensor h = L_.group_norm(x, p + "GroupNorm", {groups, 1e-5f});
    return L_.sparse_conv(h, conv, kmap, true);
  }

  // SparseResBlock: encoder blocks widen in conv2 (conv1 to max(out / 2, in)), the others in conv1.
  DeviceTensor res_block(const std::string& p, const DeviceTensor& x, int64_t out, bool encoder, const gpu::Buffer& kmap) const {
    const int64_t in = x.channels();
    const int64_t mid = encoder ? std::max(out / 2, in) : out;
    DeviceTensor h = conv_block(p + "conv1.", x, mid, kmap);
    h = conv_block(p + "conv2.", h, out, kmap);
    if (in == out) return L_.add(h, x);
    require_shape(L_, p + "skip_connection.weight", {out, in});
    return L_.add(h, L_.conv(x, p + "skip_connection"));
  }

 private:
  LayerRecorder& L_;
  const VoxelUnetConfig& c_;
};

}  // namespace

DeviceTensor voxel_lifter_gpu(VoxelBranchGpu& B, const VoxelUnetConfig& c, const DeviceTensor& image_features,
                              const std::vector<int32_t>& first_voxel, const CpuTensor& effective_mask, int64_t voxels,
                              int batch_index, VoxelBranchGpuTrace* trace) {
  if (image_features.shape.size() != 4 || image_features.channels() != c.image_channels)
    throw std::invalid_argument("gsm voxel lifter: image features " + shape_text(image_features.shape) + ", expected [N, " +
                                std::to_string(c.image_channels) + ", H, W]");
  const int64_t N = image_features.batch(), C = image_features.channels(), H = image_features.shape[2],
                W = image_features.shape[3];
  if (effective_mask.shape != std::vector<int64_t>{N, H, W})
    throw std::invalid_argument("gsm voxel lifter: effective mask " + effective_mask.shape_text() + " for features " +
                                shape_text(image_features.shape));
  if (static_cast<int64_t>(first_voxel.size()) != N * H * W)
    throw std::invalid_argument("gsm voxel lifter: " + std::to_string(first_voxel.size()) + " first-voxel rows for " +
                                std::to_string(N * H * W) + " pixels");
  if (voxels <= 0) throw std::invalid_argument("gsm voxel lifter: the grid has no voxels");
  LayerRecorder& L = B.L();
  require_shape(L, kPrefix + "lifter.mix_fc.weight", {c.in_channels, c.image_channels});
  const kernels::nn::VoxelPixelLists lists = kernels::nn::build_voxel_pixel_lists(first_voxel, effective_mask.data, u32(voxels));
  const gpu::Buffer& offsets = B.upload(lists.offsets, "gsm-lifter-offsets");
  const gpu::Buffer& pixel_ids = B.upload(lists.pixel_ids, "gsm-lifter-pixels");
  const DeviceTensor voxel_major = L.alloc({1, 1, voxels * C});
  B.scatter_mean().record(L.cmd(), {u32(N), u32(C), u32(H), u32(W)}, *image_features.buf, lists, offsets, pixel_ids,
                          *voxel_major.buf);
  L.barrier();
  const DeviceTensor mean = B.rows_to_channels(voxel_major, voxels, C);
  trace_features(trace, batch_name("vox.lifter.in", batch_index), mean);
  const DeviceTensor lifted = L.conv(mean, kPrefix + "lifter.mix_fc");
  trace_features(trace, batch_name("vox.lifter", batch_index), lifted);
  return lifted;
}

DeviceTensor voxel_unet_gpu(VoxelBranchGpu& B, const VoxelUnetConfig& c, const VoxelGridGpu& grid, const DeviceTensor& lifted,
                            int batch_index, VoxelBranchGpuTrace* trace) {
  const int64_t V = grid.host.size();
  if (lifted.shape != std::vector<int64_t>{1, c.in_channels, V})
    throw std::invalid_argument("gsm voxel unet: input " + shape_text(lifted.shape) + " for " + std::to_string(V) +
                                " voxels of width " + std::to_string(c.in_channels));
  if (V == 0 || !grid.kmap) throw std::invalid_argument("gsm voxel unet: the input grid is empty or has no kernel map");
  LayerRecorder& L = B.L();
  const std::vector<int> width = c.widths();
  const int levels = c.num_blocks;
  const BlockRecorder run(L, c);
  auto name = [&](const std::string& n) { return batch_name(n, batch_index); };

  std::vector<SparseGrid> tree{grid.host};
  for (int d = 1; d < levels; ++d) tree.push_back(gsm_hash_tree_level(grid.host, d));

  require_shape(L, kPrefix + "pre_conv.weight", {c.in_channels, c.in_channels});
  DeviceTensor x = L.conv(lifted, kPrefix + "pre_conv");
  trace_features(trace, name("vox.pre_conv"), x);

  std::vector<VoxelGridGpu> level_grids{grid};
  std::vector<DeviceTensor> encoded;
  for (int d = 0; d < levels; ++d) {
    const size_t l = static_cast<size_t>(d);
    if (d > 0) {
      x = B.max_pool_children(x, child_rows(tree[l - 1], tree[l]));
      level_grids.push_back(B.grid(tree[l]));
    }
    const std::string block = "encoders.Enc" + std::to_string(d);
    x = run.res_block(kPrefix + block + ".", x, width[l + 1], true, *level_grids[l].kmap);
    trace_sparse(trace, name("vox." + block + ".0"), x, tree[l]);
    encoded.push_back(x);
  }

  const int64_t deepest = width.back();
  const gpu::Buffer& coarsest = *level_grids.back().kmap;
  x = run.res_block(kPrefix + "pre_kl_bottleneck.pre_kl_bottleneck_0.", x, deepest, false, coarsest);
  trace_sparse(trace, name("vox.pre_kl_bottleneck.pre_kl_bottleneck_0.0"), x, tree.back());
  for (int j = 0; j < 2; ++j) {
    const std::string block = "post_kl_bottleneck.post_kl_bottleneck_" + std::to_string(j);
    x = run.res_block(kPrefix + block + ".", x, deepest, false, coarsest);
    trace_sparse(trace, name("vox." + block + ".0"), x, tree.back());
  }

  SparseGrid current = tree.back();
  for (int d = levels - 2; d >= 0; --d) {
    const size_t l = static_cast<size_t>(d);
    // The voxels the tree keeps at the current level, subdivided; [encoder features (0 where absent), upsampled].
    std::vector<int32_t> parents;
    const SparseGrid children = subdivide_members(current, tree[l + 1], parents);
    if (children.ijk.empty()) throw std::invalid_argument("gsm voxel unet: decoding level " + std::to_string(d) + " keeps no voxel");
    const DeviceTensor up = B.gather_rows(x, parents);
    const VoxelGridGpu fine = B.grid(children);
    const DeviceTensor skip = B.gather_rows(encoded[l], cpu::find_rows(tree[l], children.ijk));
    const std::string block = "decoders.Dec-" + std::to_string(levels - d);
    x = run.res_block(kPrefix + block + ".", L.concat(skip, up), width[l + 1], false, *fine.kmap);
    trace_sparse(trace, name("vox." + block + ".0"), x, children);
    current = children;
  }

  // Keep only the input voxels, in the input grid's row order.
  const std::vector<int32_t> rows = cpu::find_rows(current, grid.host.ijk);
  for (size_t r = 0; r < rows.size(); ++r)
    if (rows[r] < 0) throw std::invalid_argument("gsm voxel unet: input voxel " + std::to_string(r) + " missing after decoding");
  const DeviceTensor out = B.gather_rows(x, rows);
  if (trace) {
    trace->device["vox.out.b" + std::to_string(batch_index)] = out;
    trace_put(&trace->host, "vox.out.b" + std::to_string(batch_index) + ".ijk", ijk_tensor(grid.host));
  }
  return out;
}

}  // namespace icube::nn

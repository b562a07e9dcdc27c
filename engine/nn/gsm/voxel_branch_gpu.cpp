// The GSM voxel branch on the GPU: the shared device steps and the whole branch; see voxel_branch_gpu.h.
#include "nn/gsm/voxel_branch_gpu.h"

#include "kernels/nn/gsm_project_features.h"
#include "kernels/nn/gsm_voxel_gaussians.h"
#include "kernels/nn/scatter_mean.h"
#include "kernels/nn/sparse_conv.h"
#include "kernels/nn/sparse_grid.h"
#include "nn/gsm/voxel_heads_gpu.h"
#include "nn/gsm/voxel_unet_gpu.h"
#include "nn/vae_weights.h"

#include <numeric>
#include <stdexcept>

namespace icube::nn {

namespace {

uint32_t u32(int64_t v) { return static_cast<uint32_t>(v); }

// [1, C, rows] channel-major -> [rows, C].
CpuTensor rows_major(const std::vector<float>& cm, int64_t channels, int64_t rows) {
  CpuTensor t({rows, channels});
  for (int64_t c = 0; c < channels; ++c)
    for (int64_t r = 0; r < rows; ++r) t.data[static_cast<size_t>(r * channels + c)] = cm[static_cast<size_t>(c * rows + r)];
  return t;
}

CpuTensor download_tensor(gpu::Context& ctx, const DeviceTensor& t) {
  if (t.numel() == 0) return CpuTensor(t.shape);
  return CpuTensor(t.shape, gpu::download_vector<float>(ctx, *t.buf, t.numel()));
}

}  // namespace

std::string gsm_sparse_conv_grid_order(const std::string& conv_prefix) { return conv_prefix + ".grid_order"; }

void add_voxel_branch_gpu_tensors(const GsmWeights& w, std::map<std::string, CpuTensor>& tensors) {
  const std::string prefix = "backbone.backbone_3d.", conv = ".Conv.weight";
  for (const auto& [name, t] : w.tensors) {
    if (name.compare(0, prefix.size(), prefix) != 0 || name.size() < conv.size() ||
        name.compare(name.size() - conv.size(), conv.size(), conv) != 0)
      continue;
    if (t.rank() != 5 || t.dim(2) != 3 || t.dim(3) != 3 || t.dim(4) != 3) continue;
    const std::string base = name.substr(0, name.size() - std::string(".weight").size());
    tensors[gsm_sparse_conv_grid_order(base) + ".weight"] = fvdb020_kernel_to_grid_order(t);
  }
}

GsmTrace VoxelBranchGpuTrace::download(gpu::Context& ctx) const {
  GsmTrace out = host;
  for (const auto& [name, t] : device) {
    if (t.batch() != 1) throw std::invalid_argument("voxel branch trace: " + name + " is not [1, C, rows]");
    const std::vector<float> cm = t.numel() ? gpu::download_vector<float>(ctx, *t.buf, t.numel()) : std::vector<float>{};
    out.tensors[name] = rows_major(cm, t.channels(), t.spatial());
  }
  return out;
}

VoxelGaussians VoxelGaussiansGpu::download(gpu::Context& ctx) const {
  VoxelGaussians g;
  g.means = download_tensor(ctx, means);
  g.scales = download_tensor(ctx, scales);
  g.rotations = download_tensor(ctx, rotations);
  g.opacities = download_tensor(ctx, opacities);
  g.colors = download_tensor(ctx, colors);
  g.src_ijk = src_ijk;
  g.src_level = src_level;
  g.src_sub = src_sub;
  return g;
}

struct VoxelBranchGpu::Impl {
  kernels::nn::SparseKernelMap kmap;
  kernels::nn::SparseGridOps grid_ops;
  kernels::nn::ScatterMean scatter;
  kernels::nn::GsmProjectFeatures project;
  kernels::nn::GsmVoxelGaussians gaussians;
  std::vector<std::shared_ptr<gpu::Buffer>> kept;
  std::vector<std::unique_ptr<kernels::nn::SparseGridOps::Coarse>> pooling;

  explicit Impl(gpu::Context& ctx) : kmap(ctx), grid_ops(ctx), scatter(ctx), project(ctx), gaussians(ctx) {}
};

VoxelBranchGpu::VoxelBranchGpu(gpu::Context& ctx, LayerRecorder& L) : ctx_(ctx), L_(L), impl_(std::make_unique<Impl>(ctx)) {}

VoxelBranchGpu::~VoxelBranchGpu() = default;

kernels::nn::ScatterMean& VoxelBranchGpu::scatter_mean() { return impl_->scatter; }
kernels::nn::GsmProjectFeatures& VoxelBranchGpu::project_features() { return impl_->project; }
kernels::nn::GsmVoxelGaussians& VoxelBranchGpu::voxel_gaussians() { return impl_->gaussians; }

void VoxelBranchGpu::release() {
  impl_->kept.clear();
  impl_->pooling.clear();
}

namespace {

template <class T>
std::shared_ptr<gpu::Buffer> upload_kept(gpu::Context& ctx, const std::vector<T>& v, const std::string& name) {
  if (v.empty()) return std::make_shared<gpu::Buffer>(ctx, 4, gpu::MemoryUsage::DeviceLocal, name);
  return std::make_shared<gpu::Buffer>(gpu::upload_vector(ctx, v, name));
}

}  // namespace

const gpu::Buffer& VoxelBranchGpu::upload(const std::vector<int32_t>& v, const std::string& name) {
  impl_->kept.push_back(upload_kept(ctx_, v, name));
  return *impl_->kept.back();
}

const gpu::Buffer& VoxelBranchGpu::upload(const std::vector<uint32_t>& v, const std::string& name) {
  impl_->kept.push_back(upload_kept(ctx_, v, name));
  return *impl_->kept.back();
}

const gpu::Buffer& VoxelBranchGpu::upload(const std::vector<float>& v, const std::string& name) {
  impl_->kept.push_back(upload_kept(ctx_, v, name));
  return *impl_->kept.back();
}

VoxelGridGpu VoxelBranchGpu::grid(const SparseGrid& g) {
  VoxelGridGpu out;
  out.host = g;
  std::vector<int32_t> flat;
  flat.reserve(g.ijk.size() * 3);
  for (const Ijk& c : g.ijk) flat.insert(flat.end(), c.begin(), c.end());
  out.ijk = upload_kept(ctx_, flat, "gsm-voxel-ijk");
  impl_->kept.push_back(out.ijk);
  const uint32_t rows = out.rows();
  if (rows == 0) return out;
  const uint32_t table_size = kernels::nn::SparseKernelMap::table_size(rows);
  auto table = std::make_shared<gpu::Buffer>(ctx_, uint64_t{table_size} * 4, gpu::MemoryUsage::DeviceLocal, "gsm-voxel-hash");
  out.kmap = std::make_shared<gpu::Buffer>(ctx_, uint64_t{rows} * 27 * 4, gpu::MemoryUsage::DeviceLocal, "gsm-voxel-kmap");
  impl_->kept.push_back(table);
  impl_->kept.push_back(out.kmap);
  gpu::CommandList& cmd = L_.cmd();
  impl_->kmap.record_clear(cmd, *table, table_size);
  cmd.barrier(gpu::deps::kTransferToCompute);
  impl_->kmap.record_insert(cmd, rows, *out.ijk, *table, table_size);
  L_.barrier();
  impl_->kmap.record_map(cmd, rows, *out.ijk, *table, table_size, *out.kmap);
  L_.barrier();
  return out;
}

DeviceTensor VoxelBranchGpu::gather_rows(const DeviceTensor& x, const std::vector<int32_t>& rows) {
  const int64_t channels = x.channels(), in_rows = x.spatial();
  DeviceTensor y = L_.alloc({1, channels, static_cast<int64_t>(rows.size())});
  if (rows.empty() || channels == 0) return y;
  if (in_rows == 0) throw std::invalid_argument("voxel branch: a row gather from a tensor without rows");
  const gpu::Buffer& table = upload(rows, "gsm-voxel-rows");
  impl_->grid_ops.record_gather_rows(L_.cmd(), *x.buf, u32(in_rows), u32(channels), table, u32(static_cast<int64_t>(rows.size())), *y.buf);
  L_.barrier();
  return y;
}

DeviceTensor VoxelBranchGpu::max_pool_children(const DeviceTensor& x, const std::vector<int32_t>& child_rows) {
  if (child_rows.size() % 8 != 0) throw std::invalid_argument("voxel branch: max pooling needs 8 child rows per coarse voxel");
  const size_t coarse = child_rows.size() / 8;
  // Each coarse voxel's existing children one after the other, or one zero row where it has none; the shared
  // max-pooling kernel then maxes consecutive segments (fVDB's -inf start never survives a non-empty one).
  std::vector<int32_t> segment_rows;
  std::vector<uint32_t> begin(coarse);
  segment_rows.reserve(child_rows.size());
  for (size_t q = 0; q < coarse; ++q) {
    begin[q] = static_cast<uint32_t>(segment_rows.size());
    bool any = false;
    for (size_t o = 0; o < 8; ++o)
      if (child_rows[q * 8 + o] >= 0) {
        segment_rows.push_back(child_rows[q * 8 + o]);
        any = true;
      }
    if (!any) segment_rows.push_back(-1);
  }
  DeviceTensor y = L_.alloc({1, x.channels(), static_cast<int64_t>(coarse)});
  if (coarse == 0 || x.channels() == 0) return y;
  const DeviceTensor segments = gather_rows(x, segment_rows);
  std::vector<uint32_t> identity(segment_rows.size());
  std::iota(identity.begin(), identity.end(), 0u);
  auto c = std::make_unique<kernels::nn::SparseGridOps::Coarse>();
  c->rows = static_cast<uint32_t>(coarse);
  c->fine_rows = static_cast<uint32_t>(segment_rows.size());
  c->perm = gpu::upload_vector(ctx_, identity, "gsm-voxel-pool-order");
  c->begin = gpu::upload_vector(ctx_, begin, "gsm-voxel-pool-begin");
  impl_->grid_ops.record_max_pool(L_.cmd(), *c, *segments.buf, u32(x.channels()), *y.buf);
  L_.barrier();
  impl_->pooling.push_back(std::move(c));
  return y;
}

DeviceTensor VoxelBranchGpu::rows_to_channels(const DeviceTensor& x, int64_t rows, int64_t channels) {
  if (static_cast<int64_t>(x.numel()) != rows * channels)
    throw std::invalid_argument("voxel branch: " + std::to_string(x.numel()) + " values are not [" + std::to_string(rows) + ", " +
                                std::to_string(channels) + "]");
  // A gather of one "channel" of rows * channels elements: element c * rows + r reads r * channels + c.
  std::vector<int32_t> source(static_cast<size_t>(rows * channels));
  for (int64_t c = 0; c < channels; ++c)
    for (int64_t r = 0; r < rows; ++r) source[static_cast<size_t>(c * rows + r)] = static_cast<int32_t>(r * channels + c);
  DeviceTensor y = gather_rows(DeviceTensor{x.buf, {1, 1, rows * channels}, false}, source);
  y.shape = {1, channels, rows};
  return y;
}

VoxelBranchGpuOutputs voxel_branch_gpu(VoxelBranchGpu& B, const VoxelUnetConfig& unet, const VoxelHeadsConfig& heads,
                                       const SparseGrid& grid, const DeviceTensor& image_features,
                                       const std::vector<int32_t>& first_voxel, const CpuTensor& effective_mask,
                                       const std::vector<std::array<float, 16>>& poses,
                                       const std::vector<std::array<float, 6>>& intrinsics, int batch_index,
                                       VoxelBranchGpuTrace* trace) {
  if (heads.width_3d != unet.f_maps || heads.width_2d != unet.image_channels)
    throw std::invalid_argument("voxel branch: the heads' widths (3-D " + std::to_string(heads.width_3d) + ", 2-D " +
                                std::to_string(heads.width_2d) + ") differ from the U-Net's (" + std::to_string(unet.f_maps) +
                                ", " + std::to_string(unet.image_channels) + ")");
  VoxelBranchGpuOutputs out;
  const VoxelGridGpu input = B.grid(grid);
  const DeviceTensor lifted =
      voxel_lifter_gpu(B, unet, image_features, first_voxel, effective_mask, grid.size(), batch_index, trace);
  out.features = voxel_unet_gpu(B, unet, input, lifted, batch_index, trace);
  out.front = voxel_front_masks(first_voxel, image_features.batch(), grid.size(), batch_index, trace ? &trace->host : nullptr);
  VoxelHeadsGpuInputs in;
  in.grid = grid;
  in.voxel_features = out.features;
  in.front = out.front;
  in.image_features = image_features;
  in.effective_mask = effective_mask;
  in.poses = poses;
  in.intrinsics = intrinsics;
  out.gaussians = voxel_heads_gpu(B, heads, in, batch_index, trace);
  return out;
}

}  // namespace icube::nn

// The GSM voxel branch's Gaussian heads on the GPU; see voxel_heads_gpu.h.
#include "nn/gsm/voxel_heads_gpu.h"

#include "kernels/nn/gsm_project_features.h"
#include "kernels/nn/gsm_voxel_gaussians.h"
#include "scene/input_error.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

namespace icube::nn {

namespace {

const std::string kHybridHead = "backbone.backbone_3d.render_head_hybrid.";
const std::string k3dHead = "backbone.backbone_3d.render_head_3D.";
// From this many views on, the official code maxes the views in a loop that starts from 0
// (voxel_heads_reference.cpp's kViewsOfLoopedMax).
constexpr int64_t kViewsOfLoopedMax = 30;

void require(bool ok, const std::string& what) {
  if (!ok) throw std::invalid_argument("gsm voxel heads gpu: " + what);
}

void require_shape(const LayerRecorder& L, const std::string& name, const std::vector<int64_t>& shape) {
  const std::vector<int64_t>& have = L.params().shape(name);
  require(have == shape, name + " has shape " + shape_text(have) + ", the head needs " + shape_text(shape));
}

CpuTensor ijk_tensor(const std::vector<Ijk>& ijk) {
  CpuTensor t({static_cast<int64_t>(ijk.size()), 3});
  for (size_t r = 0; r < ijk.size(); ++r)
    for (size_t a = 0; a < 3; ++a) t.data[r * 3 + a] = static_cast<float>(ijk[r][a]);
  return t;
}

std::array<float, 3> as_float(const std::array<double, 3>& v) {
  return {static_cast<float>(v[0]), static_cast<float>(v[1]), static_cast<float>(v[2])};
}

// A LinearHead "original": GroupNorm -> 3x3x3 submanifold conv (no bias, SiLU fused) -> 1x1 conv with bias.
DeviceTensor run_head(LayerRecorder& L, const VoxelHeadsConfig& c, const std::string& prefix, const DeviceTensor& x,
                      const gpu::Buffer& kmap) {
  const int64_t ch = x.channels(), out = int64_t{c.gaussians_per_voxel} * c.gs_dim;
  const std::string conv = gsm_sparse_conv_grid_order(prefix + "SingleConv.Conv");
  require_shape(L, prefix + "SingleConv.GroupNorm.weight", {ch});
  require_shape(L, conv + ".weight", {ch, ch, 3, 3, 3});
  require_shape(L, prefix + "OutConv.weight", {out, ch});
  const uint32_t groups = ch < c.num_groups ? 1u : static_cast<uint32_t>(c.num_groups);
  DeviceTensor h = L.group_norm(x, prefix + "SingleConv.GroupNorm", {groups, 1e-5f});
  h = L.sparse_conv(h, conv, kmap, true);
  return L.conv(h, prefix + "OutConv");
}

// The children of the front voxels (lexicographic) and each child's parent row.
SparseGrid front_children(const VoxelHeadsConfig& c, const VoxelHeadsGpuInputs& in, std::vector<int32_t>& parents) {
  const int32_t f = c.occ_upsample;
  std::vector<std::pair<Ijk, int32_t>> kids;
  for (int64_t r = 0; r < in.grid.size(); ++r) {
    if (!in.front.front[static_cast<size_t>(r)]) continue;
    const Ijk& p = in.grid.ijk[static_cast<size_t>(r)];
    for (int32_t a = 0; a < f; ++a)
      for (int32_t b = 0; b < f; ++b)
        for (int32_t e = 0; e < f; ++e) kids.push_back({{p[0] * f + a, p[1] * f + b, p[2] * f + e}, static_cast<int32_t>(r)});
  }
  std::stable_sort(kids.begin(), kids.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  SparseGrid g;
  for (size_t a = 0; a < 3; ++a) {
    g.voxel_size[a] = in.grid.voxel_size[a] / f;
    g.origin[a] = in.grid.origin[a] - (f - 1) * g.voxel_size[a] / 2.0;
  }
  parents.clear();
  for (const auto& k : kids) {
    g.ijk.push_back(k.first);
    parents.push_back(k.second);
  }
  return g;
}

// The non-front voxels (lexicographic) and their rows.
SparseGrid other_voxels(const VoxelHeadsGpuInputs& in, std::vector<int32_t>& rows) {
  rows.clear();
  for (int64_t r = 0; r < in.grid.size(); ++r)
    if (!in.front.front[static_cast<size_t>(r)]) rows.push_back(static_cast<int32_t>(r));
  std::stable_sort(rows.begin(), rows.end(), [&](int32_t a, int32_t b) {
    return in.grid.ijk[static_cast<size_t>(a)] < in.grid.ijk[static_cast<size_t>(b)];
  });
  SparseGrid g;
  g.voxel_size = in.grid.voxel_size;
  g.origin = in.grid.origin;
  for (int32_t r : rows) g.ijk.push_back(in.grid.ijk[static_cast<size_t>(r)]);
  return g;
}

void check_inputs(const VoxelHeadsConfig& c, const VoxelHeadsGpuInputs& in) {
  const int64_t v = in.grid.size();
  require(in.image_features.shape.size() == 4 && in.image_features.channels() == c.width_2d,
          "image features " + shape_text(in.image_features.shape) + " are not [N, " + std::to_string(c.width_2d) + ", h, w]");
  const int64_t views = in.image_features.batch();
  require(in.effective_mask.shape == std::vector<int64_t>{views, in.image_features.shape[2], in.image_features.shape[3]},
          "effective mask " + in.effective_mask.shape_text() + " is not [N, h, w] of the features");
  require(in.voxel_features.shape == std::vector<int64_t>{1, c.width_3d, v},
          "voxel features " + shape_text(in.voxel_features.shape) + " for " + std::to_string(v) + " voxels of width " +
              std::to_string(c.width_3d));
  require(static_cast<int64_t>(in.front.front.size()) == v, "front mask of " + std::to_string(in.front.front.size()) + " voxels");
  require(static_cast<int64_t>(in.front.front_per_view.size()) == v * views, "per-view front mask is not [V, N]");
  require(static_cast<int64_t>(in.poses.size()) == views && static_cast<int64_t>(in.intrinsics.size()) == views,
          "poses and intrinsics must have one entry per view");
  require(v > 0, "the grid has no voxels");
}

struct Decoder {
  VoxelBranchGpu& B;
  const VoxelHeadsConfig& c;
  VoxelGaussiansGpu& out;

  // Appends the Gaussians of the head output raw [1, G * gs_dim, rows] on `grid` (source level `level`).
  void append(const DeviceTensor& raw, const VoxelGridGpu& grid, int32_t level) {
    const uint32_t rows = grid.rows();
    kernels::nn::GsmVoxelGaussiansShape s;
    s.rows = rows;
    s.per_voxel = static_cast<uint32_t>(c.gaussians_per_voxel);
    s.gs_dim = static_cast<uint32_t>(c.gs_dim);
    s.first_gaussian = static_cast<uint32_t>(out.count());
    s.voxel_size = as_float(grid.host.voxel_size);
    s.origin = as_float(grid.host.origin);
    s.scale_unit = static_cast<float>(grid.host.voxel_size[0]);
    s.max_scaling = static_cast<float>(c.max_scaling);
    B.voxel_gaussians().record(B.L().cmd(), s, *raw.buf, *grid.ijk,
                               {out.means.buf.get(), out.scales.buf.get(), out.rotations.buf.get(), out.opacities.buf.get(),
                                out.colors.buf.get()});
    for (uint32_t r = 0; r < rows; ++r)
      for (int32_t sub = 0; sub < c.gaussians_per_voxel; ++sub) {
        const Ijk& q = grid.host.ijk[r];
        out.src_ijk.insert(out.src_ijk.end(), q.begin(), q.end());
        out.src_level.push_back(level);
        out.src_sub.push_back(sub);
      }
  }
};

}  // namespace

VoxelGaussiansGpu voxel_heads_gpu(VoxelBranchGpu& B, const VoxelHeadsConfig& c, const VoxelHeadsGpuInputs& in,
                                  int batch_index, VoxelBranchGpuTrace* trace) {
  check_inputs(c, in);
  LayerRecorder& L = B.L();
  const std::string b = ".b" + std::to_string(batch_index);
  const int64_t views = in.image_features.batch(), c2 = in.image_features.channels(), h = in.image_features.shape[2],
                w = in.image_features.shape[3], c3 = c.width_3d, V = in.grid.size();
  const int64_t G = c.gaussians_per_voxel;

  std::vector<int32_t> parents, others;
  const SparseGrid occ = front_children(c, in, parents);
  const SparseGrid rest = c.drop_invisible ? SparseGrid{} : other_voxels(in, others);
  const int64_t n = (occ.size() + rest.size()) * G;

  VoxelGaussiansGpu out;
  out.means = L.alloc({n, 3});
  out.scales = L.alloc({n, 3});
  out.rotations = L.alloc({n, 4});
  out.opacities = L.alloc({n, 1});
  out.colors = L.alloc({n, int64_t{c.gs_dim} - 11});
  Decoder decode{B, c, out};

  if (trace) trace_put(&trace->host, "vox.occ" + b + ".ijk", ijk_tensor(occ.ijk));
  if (occ.size() == 0) {
    if (trace) trace->device["vox.occ" + b + ".head_in"] = L.alloc({1, c2 + c3, 0});
  } else {
    const VoxelGridGpu grid = B.grid(occ);
    // The 2-D part: projected, sampled, masked by the per-view first hits, maxed over the views.
    std::vector<double> proj;
    for (const std::array<double, 12>& m : gsm_world_to_normalized_image(in.poses, in.intrinsics)) proj.insert(proj.end(), m.begin(), m.end());
    std::vector<uint32_t> seen(in.front.front_per_view.begin(), in.front.front_per_view.end());
    kernels::nn::GsmProjectShape s;
    s.rows = grid.rows();
    s.parents = static_cast<uint32_t>(V);
    s.channels = static_cast<uint32_t>(c2);
    s.views = static_cast<uint32_t>(views);
    s.height = static_cast<uint32_t>(h);
    s.width = static_cast<uint32_t>(w);
    s.voxel_size = occ.voxel_size;
    s.origin = occ.origin;
    s.max_from_zero = views >= kViewsOfLoopedMax;
    const DeviceTensor projected = L.alloc({1, c2, occ.size()});
    const gpu::Buffer& mask = B.upload(in.effective_mask.data, "gsm-effective-mask");
    const gpu::Buffer& parent_rows = B.upload(parents, "gsm-occ-parents");
    const gpu::Buffer& seen_table = B.upload(seen, "gsm-occ-seen");
    const gpu::Buffer& projections = B.upload(kernels::nn::gsm_projection_pairs(proj), "gsm-projections");
    for (const kernels::nn::GsmProjectWindow& win : B.project_features().windows(s)) {
      if (win.barrier_before) L.barrier();  // later views take the maximum with the earlier ones' output
      B.project_features().record(L.cmd(), s, win, *in.image_features.buf, mask, *grid.ijk, parent_rows, seen_table,
                                  projections, *projected.buf);
    }
    L.barrier();
    const DeviceTensor head_in = L.concat(projected, B.gather_rows(in.voxel_features, parents));
    const DeviceTensor head_out = run_head(L, c, kHybridHead, head_in, *grid.kmap);
    if (trace) {
      trace->device["vox.occ" + b + ".head_in"] = head_in;
      trace->device["vox.occ" + b + ".head_out"] = head_out;
    }
    decode.append(head_out, grid, 0);
  }

  if (!c.drop_invisible) {
    if (trace) trace_put(&trace->host, "vox.nonocc" + b + ".ijk", ijk_tensor(rest.ijk));
    const DeviceTensor head_in = rest.size() ? B.gather_rows(in.voxel_features, others) : L.alloc({1, c3, 0});
    if (trace) trace->device["vox.nonocc" + b + ".head_in"] = head_in;
    if (rest.size() > 0) {
      const VoxelGridGpu grid = B.grid(rest);
      const DeviceTensor head_out = run_head(L, c, k3dHead, head_in, *grid.kmap);
      if (trace) trace->device["vox.nonocc" + b + ".head_out"] = head_out;
      decode.append(head_out, grid, 1);
    }
  }
  L.barrier();
  return out;
}

}  // namespace icube::nn

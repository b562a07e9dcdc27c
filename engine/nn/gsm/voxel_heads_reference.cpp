// The GSM voxel branch's Gaussian heads and their decoding; see voxel_heads_reference.h.
// Test: tests/nn/test_gsm_voxel_heads_reference.cpp.
#include "nn/gsm/voxel_heads_reference.h"

#include "nn/gsm/gsm_json.h"
#include "nn/vae_weights.h"
#include "scene/input_error.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <string>

namespace icube::nn {

namespace {

const std::string kParams = "backbone.params.backbone_3d_params";
const std::string kHybridHead = "backbone.backbone_3d.render_head_hybrid.";
const std::string k3dHead = "backbone.backbone_3d.render_head_3D.";
// From this many views on, the official code maxes the views in a loop that starts from 0.
constexpr int64_t kViewsOfLoopedMax = 30;

void require(bool ok, const std::string& what) {
  if (!ok) throw std::invalid_argument("gsm voxel heads: " + what);
}

// The optional backbone_3d parameter `key` must be `want` (the only setting implemented here).
void require_text(const nlohmann::json& hparams, const std::string& key, const std::string& want) {
  const std::string path = kParams + "." + key;
  if (gsm_json::has(hparams, path) && gsm_json::text(hparams, path) != want)
    throw scene::InputError("the GSM config", path, "only \"" + want + "\" is implemented");
}

// Rows of `ijk` sorted by ijk (lexicographic); the permutation.
std::vector<int64_t> lexicographic_order(const std::vector<Ijk>& ijk) {
  std::vector<int64_t> order(ijk.size());
  std::iota(order.begin(), order.end(), int64_t{0});
  std::stable_sort(order.begin(), order.end(), [&](int64_t a, int64_t b) { return ijk[static_cast<size_t>(a)] < ijk[static_cast<size_t>(b)]; });
  return order;
}

CpuTensor ijk_tensor(const std::vector<Ijk>& ijk) {
  CpuTensor t({static_cast<int64_t>(ijk.size()), 3});
  for (size_t r = 0; r < ijk.size(); ++r)
    for (int a = 0; a < 3; ++a) t.data[r * 3 + static_cast<size_t>(a)] = static_cast<float>(ijk[r][static_cast<size_t>(a)]);
  return t;
}

CpuTensor features_tensor(const SparseTensor& x) { return CpuTensor({x.rows(), x.channels}, x.data); }

// A LinearHead "original": GroupNorm -> 3x3x3 submanifold conv (no bias) -> SiLU -> 1x1 conv with bias,
// on x's own grid.
SparseTensor run_head(const VoxelHeadsConfig& c, const GsmWeights& w, const std::string& prefix, const SparseTensor& x) {
  const int64_t ch = x.channels, out = int64_t{c.gaussians_per_voxel} * c.gs_dim;
  const int groups = ch < c.num_groups ? 1 : c.num_groups;
  const CpuTensor& gn_w = w.at(prefix + "SingleConv.GroupNorm.weight", {ch});
  const CpuTensor& gn_b = w.at(prefix + "SingleConv.GroupNorm.bias", {ch});
  const CpuTensor conv_w = fvdb020_kernel_to_grid_order(w.at(prefix + "SingleConv.Conv.weight", {ch, ch, 3, 3, 3}));
  const CpuTensor& out_w = w.at(prefix + "OutConv.weight", {out, ch});
  const CpuTensor& out_b = w.at(prefix + "OutConv.bias", {out});
  SparseTensor h = cpu::group_norm(x, groups, gn_w, gn_b);
  h = cpu::silu(cpu::conv3d(h, conv_w, nullptr));
  return cpu::linear(h, out_w, &out_b);
}


// F.grid_sample(bilinear, zeros, align_corners=False) of the masked feature map `view` [C, h, w] at the
// normalised image point (u, v) in [0, 1] (pixel x = u * w - 0.5), written to `out` [C].
void sample_bilinear(const float* features, const float* mask, int64_t channels, int64_t h, int64_t w, double u, double v,
                     std::vector<double>& out) {
  std::fill(out.begin(), out.end(), 0.0);
  const double x = u * static_cast<double>(w) - 0.5, y = v * static_cast<double>(h) - 0.5;
  if (!std::isfinite(x) || !std::isfinite(y)) return;
  const double x0 = std::floor(x), y0 = std::floor(y);
  const double fx = x - x0, fy = y - y0;
  for (int dy = 0; dy < 2; ++dy)
    for (int dx = 0; dx < 2; ++dx) {
      const double col = x0 + dx, row = y0 + dy;
      if (col < 0 || row < 0 || col >= static_cast<double>(w) || row >= static_cast<double>(h)) continue;
      const double weight = (dx ? fx : 1.0 - fx) * (dy ? fy : 1.0 - fy);
      const int64_t pix = static_cast<int64_t>(row) * w + static_cast<int64_t>(col);
      if (!(mask[pix] > 0.0f)) continue;  // features * (effective mask > 0)
      for (int64_t ci = 0; ci < channels; ++ci) out[static_cast<size_t>(ci)] += weight * static_cast<double>(features[ci * h * w + pix]);
    }
}

// The children of the front voxels, sorted by ijk, with [2-D feature, copied 3-D feature] rows.
SparseTensor front_children_features(const VoxelHeadsConfig& c, const VoxelHeadsInputs& in) {
  const int f = c.occ_upsample;
  const int64_t views = in.image_features.dim(0), c2 = in.image_features.dim(1), h = in.image_features.dim(2),
                w = in.image_features.dim(3), c3 = c.width_3d;
  std::vector<Ijk> ijk;
  std::vector<int64_t> parent;
  for (int64_t r = 0; r < in.grid.size(); ++r) {
    if (!in.front[static_cast<size_t>(r)]) continue;
    const Ijk& p = in.grid.ijk[static_cast<size_t>(r)];
    for (int a = 0; a < f; ++a)
      for (int b = 0; b < f; ++b)
        for (int e = 0; e < f; ++e) {
          ijk.push_back({p[0] * f + a, p[1] * f + b, p[2] * f + e});
          parent.push_back(r);
        }
  }
  const std::vector<int64_t> order = lexicographic_order(ijk);
  SparseTensor x;
  for (int a = 0; a < 3; ++a) {
    const size_t s = static_cast<size_t>(a);
    x.grid.voxel_size[s] = in.grid.voxel_size[s] / f;
    x.grid.origin[s] = in.grid.origin[s] - (f - 1) * x.grid.voxel_size[s] / 2.0;
  }
  x.channels = c2 + c3;
  x.data.assign(order.size() * static_cast<size_t>(x.channels), 0.0f);
  const std::vector<std::array<double, 12>> proj = gsm_world_to_normalized_image(in.poses, in.intrinsics);
  std::vector<double> sample(static_cast<size_t>(c2)), best(static_cast<size_t>(c2));
  for (size_t r = 0; r < order.size(); ++r) {
    const Ijk& q = ijk[static_cast<size_t>(order[r])];
    const int64_t src = parent[static_cast<size_t>(order[r])];
    x.grid.ijk.push_back(q);
    double xyz[3];
    for (int a = 0; a < 3; ++a) xyz[a] = q[static_cast<size_t>(a)] * x.grid.voxel_size[static_cast<size_t>(a)] + x.grid.origin[static_cast<size_t>(a)];
    // Before the first view: the looped maximum (many views) starts from 0, torch.max over the views from view 0.
    std::fill(best.begin(), best.end(), views >= kViewsOfLoopedMax ? 0.0 : -std::numeric_limits<double>::infinity());
    for (int64_t n = 0; n < views; ++n) {
      const std::array<double, 12>& m = proj[static_cast<size_t>(n)];
      double pt[3];
      for (int s = 0; s < 3; ++s) pt[s] = m[static_cast<size_t>(s * 4)] * xyz[0] + m[static_cast<size_t>(s * 4 + 1)] * xyz[1] + m[static_cast<size_t>(s * 4 + 2)] * xyz[2] + m[static_cast<size_t>(s * 4 + 3)];
      sample_bilinear(in.image_features.data.data() + n * c2 * h * w, in.effective_mask.data.data() + n * h * w, c2, h, w,
                      pt[0] / pt[2], pt[1] / pt[2], sample);
      const bool saw_parent_first = in.front_per_view[static_cast<size_t>(src * views + n)] != 0;
      for (int64_t ci = 0; ci < c2; ++ci) {
        const double v = saw_parent_first ? sample[static_cast<size_t>(ci)] : 0.0;
        best[static_cast<size_t>(ci)] = std::max(best[static_cast<size_t>(ci)], v);
      }
    }
    float* row = x.row(static_cast<int64_t>(r));
    for (int64_t ci = 0; ci < c2; ++ci) row[ci] = static_cast<float>(best[static_cast<size_t>(ci)]);
    const float* feat3 = in.voxel_features.data.data() + src * c3;
    std::copy(feat3, feat3 + c3, row + c2);
  }
  return x;
}

// The non-front voxels, sorted by ijk, with their 3-D features.
SparseTensor other_voxel_features(const VoxelHeadsConfig& c, const VoxelHeadsInputs& in) {
  std::vector<Ijk> ijk;
  std::vector<int64_t> rows;
  for (int64_t r = 0; r < in.grid.size(); ++r)
    if (!in.front[static_cast<size_t>(r)]) {
      ijk.push_back(in.grid.ijk[static_cast<size_t>(r)]);
      rows.push_back(r);
    }
  SparseTensor x;
  x.grid.voxel_size = in.grid.voxel_size;
  x.grid.origin = in.grid.origin;
  x.channels = c.width_3d;
  for (int64_t k : lexicographic_order(ijk)) {
    x.grid.ijk.push_back(ijk[static_cast<size_t>(k)]);
    const float* src = in.voxel_features.data.data() + rows[static_cast<size_t>(k)] * c.width_3d;
    x.data.insert(x.data.end(), src, src + c.width_3d);
  }
  return x;
}

double sigmoid(double v) { return 1.0 / (1.0 + std::exp(-v)); }

// feature2gs: the head's raw values of every voxel of raw.grid appended as Gaussians of `level`.
void append_gaussians(const VoxelHeadsConfig& c, const SparseTensor& raw, int32_t level, VoxelGaussians& g,
                      std::vector<float>& means, std::vector<float>& scales, std::vector<float>& rotations,
                      std::vector<float>& opacities, std::vector<float>& colors) {
  const SparseGrid& grid = raw.grid;
  const int color_dim = c.gs_dim - 11;
  for (int64_t r = 0; r < raw.rows(); ++r) {
    const Ijk& q = grid.ijk[static_cast<size_t>(r)];
    for (int sub = 0; sub < c.gaussians_per_voxel; ++sub) {
      const float* v = raw.row(r) + sub * c.gs_dim;
      for (int a = 0; a < 3; ++a) {
        const size_t s = static_cast<size_t>(a);
        const double min_corner = (q[s] - 0.5) * grid.voxel_size[s] + grid.origin[s];
        means.push_back(static_cast<float>(min_corner + sigmoid(v[a]) * grid.voxel_size[s]));
      }
      for (int a = 0; a < 3; ++a) {
        double s = std::exp(static_cast<double>(v[3 + a])) * grid.voxel_size[0];
        if (c.max_scaling > 0.0) s = std::min(s, c.max_scaling);
        scales.push_back(static_cast<float>(s));
      }
      double norm = 0.0;
      for (int a = 0; a < 4; ++a) norm += static_cast<double>(v[6 + a]) * static_cast<double>(v[6 + a]);
      norm = std::max(std::sqrt(norm), 1e-12);
      for (int a = 0; a < 4; ++a) rotations.push_back(static_cast<float>(static_cast<double>(v[6 + a]) / norm));
      opacities.push_back(static_cast<float>(sigmoid(v[10])));
      for (int a = 0; a < color_dim; ++a) colors.push_back(v[11 + a]);
      g.src_ijk.insert(g.src_ijk.end(), q.begin(), q.end());
      g.src_level.push_back(level);
      g.src_sub.push_back(sub);
    }
  }
}

void check_inputs(const VoxelHeadsConfig& c, const VoxelHeadsInputs& in) {
  const int64_t v = in.grid.size();
  require(in.image_features.rank() == 4 && in.image_features.dim(1) == c.width_2d,
          "image features " + in.image_features.shape_text() + " are not [N, " + std::to_string(c.width_2d) + ", h, w]");
  const int64_t views = in.image_features.dim(0);
  require(in.effective_mask.shape == std::vector<int64_t>{views, in.image_features.dim(2), in.image_features.dim(3)},
          "effective mask " + in.effective_mask.shape_text() + " is not [N, h, w] of the features");
  require(in.voxel_features.shape == std::vector<int64_t>{v, c.width_3d},
          "voxel features " + in.voxel_features.shape_text() + " for " + std::to_string(v) + " voxels of width " + std::to_string(c.width_3d));
  require(static_cast<int64_t>(in.front.size()) == v, "front mask of " + std::to_string(in.front.size()) + " voxels");
  require(static_cast<int64_t>(in.front_per_view.size()) == v * views, "per-view front mask is not [V, N]");
  require(static_cast<int64_t>(in.poses.size()) == views && static_cast<int64_t>(in.intrinsics.size()) == views,
          "poses and intrinsics must have one entry per view");
}

}  // namespace

VoxelHeadsConfig voxel_heads_config_from_json(const nlohmann::json& hparams) {
  auto key = [](const std::string& k) { return kParams + "." + k; };
  auto optional_int = [&](const std::string& k, int fallback) { return gsm_json::has(hparams, key(k)) ? gsm_json::integer(hparams, key(k)) : fallback; };
  VoxelHeadsConfig c;
  c.width_3d = optional_int("f_maps", 64);
  c.width_2d = optional_int("f_maps_2d", 32);
  c.gaussians_per_voxel = optional_int("gsplat_upsample", 1);
  c.gs_dim = optional_int("gs_dim", 14);
  c.occ_upsample = optional_int("occ_upsample", 2);
  c.num_groups = optional_int("num_groups", 8);
  c.max_scaling = gsm_json::has(hparams, key("max_scaling")) ? gsm_json::number(hparams, key("max_scaling")) : 0.0;
  c.drop_invisible = gsm_json::has(hparams, key("drop_invisible")) && gsm_json::boolean(hparams, key("drop_invisible"));
  require_text(hparams, "order", "gcs");
  require_text(hparams, "gs_free_space", "hard");
  require_text(hparams, "feature_pooling_2d", "max");
  if (gsm_json::text(hparams, key("gs_enhanced")) != "original")
    throw scene::InputError("the GSM config", key("gs_enhanced"), "only \"original\" (GroupNorm, conv, SiLU, 1x1 conv) is implemented");
  if (gsm_json::has(hparams, key("with_render_branch")) && !gsm_json::boolean(hparams, key("with_render_branch")))
    throw scene::InputError("the GSM config", key("with_render_branch"), "the voxel branch needs its render heads");
  if (c.width_3d < 1 || c.width_2d < 1 || c.gaussians_per_voxel < 1 || c.occ_upsample < 1 || c.num_groups < 1 || c.gs_dim < 12)
    throw scene::InputError("the GSM config", kParams, "f_maps, f_maps_2d, gsplat_upsample, occ_upsample, num_groups must be >= 1, gs_dim >= 12");
  return c;
}

VoxelGaussians voxel_heads_forward(const VoxelHeadsConfig& c, const GsmWeights& w, const VoxelHeadsInputs& in,
                                   int batch_index, GsmTrace* trace) {
  check_inputs(c, in);
  const std::string b = ".b" + std::to_string(batch_index);
  VoxelGaussians g;
  std::vector<float> means, scales, rotations, opacities, colors;

  const SparseTensor occ_in = front_children_features(c, in);
  trace_put(trace, "vox.occ" + b + ".ijk", ijk_tensor(occ_in.grid.ijk));
  trace_put(trace, "vox.occ" + b + ".head_in", features_tensor(occ_in));
  if (occ_in.rows() > 0) {
    const SparseTensor occ_out = run_head(c, w, kHybridHead, occ_in);
    trace_put(trace, "vox.occ" + b + ".head_out", features_tensor(occ_out));
    append_gaussians(c, occ_out, 0, g, means, scales, rotations, opacities, colors);
  }

  if (!c.drop_invisible) {
    const SparseTensor other_in = other_voxel_features(c, in);
    trace_put(trace, "vox.nonocc" + b + ".ijk", ijk_tensor(other_in.grid.ijk));
    trace_put(trace, "vox.nonocc" + b + ".head_in", features_tensor(other_in));
    if (other_in.rows() > 0) {
      const SparseTensor other_out = run_head(c, w, k3dHead, other_in);
      trace_put(trace, "vox.nonocc" + b + ".head_out", features_tensor(other_out));
      append_gaussians(c, other_out, 1, g, means, scales, rotations, opacities, colors);
    }
  }

  const int64_t n = g.count();
  g.means = CpuTensor({n, 3}, std::move(means));
  g.scales = CpuTensor({n, 3}, std::move(scales));
  g.rotations = CpuTensor({n, 4}, std::move(rotations));
  g.opacities = CpuTensor({n, 1}, std::move(opacities));
  g.colors = CpuTensor({n, int64_t{c.gs_dim} - 11}, std::move(colors));
  return g;
}

std::vector<std::array<double, 12>> gsm_world_to_normalized_image(const std::vector<std::array<float, 16>>& poses,
                                                                 const std::vector<std::array<float, 6>>& intrinsics) {
  if (poses.size() != intrinsics.size()) throw std::invalid_argument("gsm projection: poses and intrinsics differ in count");
  std::vector<std::array<double, 12>> out;
  for (size_t n = 0; n < poses.size(); ++n) {
    const std::array<float, 16>& p = poses[n];
    // Grid-to-camera = torch.inverse(camera-to-grid): the general 4x4 inverse (Gauss-Jordan), in double.
    double m[4][8];
    for (int r = 0; r < 4; ++r)
      for (int q = 0; q < 8; ++q) m[r][q] = q < 4 ? static_cast<double>(p[static_cast<size_t>(r * 4 + q)]) : (q - 4 == r ? 1.0 : 0.0);
    for (int col = 0; col < 4; ++col) {
      int piv = col;
      for (int r = col + 1; r < 4; ++r)
        if (std::fabs(m[r][col]) > std::fabs(m[piv][col])) piv = r;
      if (m[piv][col] == 0.0) throw scene::InputError("poses", "view " + std::to_string(n), "the camera pose is singular");
      for (int q = 0; q < 8; ++q) std::swap(m[col][q], m[piv][q]);
      const double d = m[col][col];
      for (int q = 0; q < 8; ++q) m[col][q] /= d;
      for (int r = 0; r < 4; ++r) {
        if (r == col) continue;
        const double f = m[r][col];
        for (int q = 0; q < 8; ++q) m[r][q] -= f * m[col][q];
      }
    }
    const std::array<float, 6>& k = intrinsics[n];
    const double fx = k[0], fy = k[1], cx = k[2], cy = k[3], width = k[4], height = k[5];
    const double kn[3][3] = {{fx / width, 0.0, cx / width}, {0.0, fy / height, cy / height}, {0.0, 0.0, 1.0}};
    std::array<double, 12> a{};
    for (int r = 0; r < 3; ++r)
      for (int q = 0; q < 4; ++q)
        for (int s = 0; s < 3; ++s) a[static_cast<size_t>(r * 4 + q)] += kn[r][s] * m[s][4 + q];
    out.push_back(a);
  }
  return out;
}

}  // namespace icube::nn

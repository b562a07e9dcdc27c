// FLOP counts of one GSM forward by stage; see gsm_flops.h.
#include "gsm_flops.h"

#include "nn/gsm/gsm_rays.h"
#include "nn/gsm/voxel_unet_reference.h"

#include <algorithm>
#include <cctype>
#include <string>

namespace icube::bench {

namespace {

double numel(const nn::GsmWeights& w, const std::string& name) { return static_cast<double>(w.at(name).numel()); }

bool starts_with(const std::string& s, const std::string& p) { return s.rfind(p, 0) == 0; }
bool ends_with(const std::string& s, const std::string& p) {
  return s.size() >= p.size() && s.compare(s.size() - p.size(), p.size(), p) == 0;
}

// The integer after `key` in `name` ("downs.2.0..." with key "downs." -> 2), or -1.
int index_after(const std::string& name, const std::string& key) {
  const size_t at = name.find(key);
  if (at == std::string::npos) return -1;
  size_t i = at + key.size(), n = 0;
  while (i + n < name.size() && std::isdigit(static_cast<unsigned char>(name[i + n]))) ++n;
  return n ? std::stoi(name.substr(i, n)) : -1;
}

// Conv / linear weights under `prefix` (rank >= 2, named *.weight).
template <class F>
void for_each_weight(const nn::GsmWeights& w, const std::string& prefix, F&& f) {
  for (const auto& [name, t] : w.tensors)
    if (starts_with(name, prefix) && ends_with(name, ".weight") && t.rank() >= 2) f(name, static_cast<double>(t.numel()));
}

double conv_encoder_flops_per_view(const nn::GsmWeights& w, double pixels) {
  double f = 0;
  for_each_weight(w, "img_encoder.encoders.conv.", [&](const std::string&, double n) { f += 2 * n * pixels; });
  return f;
}

double xunet_flops_per_view(const nn::PixelBranchConfig& c, const nn::GsmWeights& w, int64_t H, int64_t W) {
  const std::string p = "backbone.backbone_2d.net.";
  const int S = c.unet.stages();
  auto px = [&](int level) { return static_cast<double>(H >> level) * static_cast<double>(W >> level); };
  double f = 0;
  for_each_weight(w, p, [&](const std::string& name, double n) {
    const std::string local = name.substr(p.size());
    int level = 0;
    if (starts_with(local, "downs.")) {
      const int s = index_after(local, "downs.");
      level = local.find("downs." + std::to_string(s) + ".3.") == 0 ? s + 1 : s;
    } else if (starts_with(local, "ups.")) {
      level = S - 1 - index_after(local, "ups.");
    } else if (starts_with(local, "mid")) {
      level = S;
    }
    // Transposed convolutions (mid_upsample, ups.u.3) cost 2 |W| per input pixel, like the others per output pixel.
    f += 2 * n * px(level);
  });
  // The mid attention's core over the coarsest map.
  const std::string out = p + "mid_attn.to_out.weight";
  if (w.has(out)) {
    const double T = px(S), inner = static_cast<double>(w.at(out).dim(1));
    f += 4 * T * T * inner;
  }
  return f + 2 * numel(w, "backbone.backbone_2d.linear_out.weight") * static_cast<double>(H * W);
}

double voxel_branch_flops(const nn::GsmConfig& c, const nn::GsmWeights& w, const nn::GsmInputs& in, int64_t b) {
  const nn::SparseGrid grid = nn::gsm_input_grid(in, b);
  const int L = c.voxel_unet.num_blocks;
  std::vector<double> rows{static_cast<double>(grid.size())};
  for (int d = 1; d < L; ++d) rows.push_back(static_cast<double>(nn::gsm_hash_tree_level(grid, d).size()));
  // The heads: the voxels some view hits first are split into occ_upsample^3 children, the others stay.
  const nn::GsmPixelRays rays = nn::cast_gsm_pixel_rays(in, b);
  std::vector<uint8_t> front(static_cast<size_t>(grid.size()), 0);
  for (int32_t row : rays.first_voxel)
    if (row >= 0) front[static_cast<size_t>(row)] = 1;
  const double fronts = static_cast<double>(std::count(front.begin(), front.end(), uint8_t{1}));
  const double k = c.voxel_heads.occ_upsample;
  const double children = fronts * k * k * k, others = rows[0] - fronts;
  const std::string p = "backbone.backbone_3d.";
  double f = 0;
  for_each_weight(w, p, [&](const std::string& name, double n) {
    const std::string local = name.substr(p.size());
    double r = 0;
    if (starts_with(local, "lifter.") || starts_with(local, "pre_conv.")) r = rows[0];
    else if (starts_with(local, "encoders.Enc")) r = rows[static_cast<size_t>(index_after(local, "encoders.Enc"))];
    else if (local.find("_kl_bottleneck.") != std::string::npos) r = rows.back();
    else if (starts_with(local, "decoders.Dec-")) r = 8 * rows[static_cast<size_t>(L - index_after(local, "decoders.Dec-") + 1)];
    else if (starts_with(local, "render_head_hybrid.")) r = children;
    else if (starts_with(local, "render_head_3D.")) r = others;
    f += 2 * n * r;  // struct_convs are not run (r = 0)
  });
  return f;
}

// Patches of > 75 % sky pixels in batch element b (the sky token's tokens, without the query).
double sky_patches(const nn::GsmInputs& in, int64_t b, int P) {
  double count = 0;
  for (int64_t n = 0; n < in.views; ++n)
    for (int64_t pr = 0; pr < in.height / P; ++pr)
      for (int64_t pc = 0; pc < in.width / P; ++pc) {
        int64_t sky = 0;
        for (int64_t r = pr * P; r < (pr + 1) * P; ++r)
          for (int64_t col = pc * P; col < (pc + 1) * P; ++col) sky += in.mask(b, n, r, col, 0) == 0 ? 1 : 0;
        if (4 * sky > 3 * P * P) count += 1;
      }
  return count;
}

}  // namespace

double dav2_flops_per_view(const nn::Dav2Config& c, const nn::GsmWeights& w) {
  const std::string m = "img_encoder.encoders.dav2.model.";
  const double gh = static_cast<double>(c.input_height / c.patch_size), gw = static_cast<double>(c.input_width / c.patch_size);
  const double T = 1 + gh * gw, C = static_cast<double>(c.hidden_size);
  double f = 2 * numel(w, m + "backbone.embeddings.patch_embeddings.projection.weight") * gh * gw;
  const int64_t layers = std::min(c.num_layers, *std::max_element(c.out_indices.begin(), c.out_indices.end()));
  for (int64_t i = 0; i < layers; ++i) {
    double n = 0;
    for_each_weight(w, m + "backbone.encoder.layer." + std::to_string(i) + ".", [&](const std::string&, double k) { n += k; });
    f += 2 * n * T + 4 * T * T * C;
  }
  // Neck: sizes of the reassembled maps, coarsest last.
  std::vector<double> size;
  for (size_t k = 0; k < c.out_indices.size(); ++k) {
    const std::string r = m + "neck.reassemble_stage.layers." + std::to_string(k) + ".";
    const double factor = c.reassemble_factors[k];
    f += 2 * numel(w, r + "projection.weight") * gh * gw;
    double h = gh, wd = gw;
    if (factor > 1.0) {
      f += 2 * numel(w, r + "resize.weight") * gh * gw;
      h *= factor;
      wd *= factor;
    } else if (factor < 1.0) {
      const int64_t s = static_cast<int64_t>(1.0 / factor);
      h = static_cast<double>((static_cast<int64_t>(gh) - 1) / s + 1);
      wd = static_cast<double>((static_cast<int64_t>(gw) - 1) / s + 1);
      f += 2 * numel(w, r + "resize.weight") * h * wd;
    }
    size.push_back(h * wd);
    f += 2 * numel(w, m + "neck.convs." + std::to_string(k) + ".weight") * h * wd;
  }
  const size_t n = size.size();
  double fused = 0;
  for (size_t i = 0; i < n; ++i) {
    const std::string p = m + "neck.fusion_stage.layers." + std::to_string(i) + ".";
    const double at = size[n - 1 - i], out = i + 1 == n ? 4 * at : size[n - 2 - i];
    if (i > 0) f += 2 * (numel(w, p + "residual_layer1.convolution1.weight") + numel(w, p + "residual_layer1.convolution2.weight")) * at;
    f += 2 * (numel(w, p + "residual_layer2.convolution1.weight") + numel(w, p + "residual_layer2.convolution2.weight")) * at;
    f += 2 * numel(w, p + "projection.weight") * out;
    fused = out;
  }
  for (size_t j = 0; j < c.upsampler.size(); ++j) {
    if (c.upsampler[j].up) fused *= 4;
    if (c.upsampler[j].down) fused /= 4;
    double k = 0;
    for_each_weight(w, "img_encoder.encoders.dav2.upsampler." + std::to_string(j) + ".", [&](const std::string&, double v) { k += v; });
    f += 2 * k * fused;
  }
  return f;
}

GsmFlops gsm_flops(const nn::GsmConfig& c, const nn::GsmWeights& w, const nn::GsmInputs& in) {
  GsmFlops g;
  const double views = static_cast<double>(in.batch * in.views), pixels = static_cast<double>(in.height * in.width);
  g.conv_encoder = views * conv_encoder_flops_per_view(w, pixels);
  g.dav2_per_view = dav2_flops_per_view(c.dav2, w);
  g.dav2 = views * g.dav2_per_view;
  g.pixel_branch = views * xunet_flops_per_view(c.pixel, w, in.height, in.width);
  for (int64_t b = 0; b < in.batch; ++b) g.voxel_branch += voxel_branch_flops(c, w, in, b);

  const int P = c.sky.patch_size;
  const double E = c.sky.embed_dim;
  g.sky_token = 2 * numel(w, "skybox.patch_embedder.weight") * views * pixels / (P * P);
  for (int64_t b = 0; b < in.batch; ++b) {
    const double T = 1 + sky_patches(in, b, P);
    for (int l = 0; l < c.sky.layers; ++l) {
      double n = 0;
      for_each_weight(w, "skybox.transformer.layers." + std::to_string(l) + ".", [&](const std::string&, double k) { n += k; });
      g.sky_token += 2 * (n + numel(w, "skybox.transformer.layers." + std::to_string(l) + ".self_attn.in_proj_weight")) * T +
                     4 * T * T * E;
    }
  }
  const double rows = static_cast<double>(c.sky_panorama_rows);
  g.sky_colours = 2 * (numel(w, "skybox.modulator.pos_emb.weight") + numel(w, "skybox.modulator.output.weight")) *
                  (views * pixels + static_cast<double>(in.batch) * 2 * rows * rows);
  return g;
}

}  // namespace icube::bench

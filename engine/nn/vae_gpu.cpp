// The structure VAE decoder on the GPU; see vae_gpu.h.
#include "nn/vae_gpu.h"

#include "nn/activation_pool.h"

#include "nn/conv3d.h"
#include "nn/elementwise.h"
#include "nn/group_norm.h"
#include "nn/sparse_conv.h"
#include "nn/sparse_grid.h"

#include <chrono>
#include <stdexcept>

namespace icube::nn {

namespace {

// A GPU sparse tensor's features: channel-major [channels][rows] in a pooled buffer.
struct GT {
  uint32_t channels = 0, rows = 0;
  std::shared_ptr<gpu::Buffer> buf;
  uint64_t numel() const { return uint64_t{channels} * rows; }
};

// A level's grid on the device: coordinates and the 3^3 kernel map (built once, used by every conv there).
struct Level {
  SparseGrid host;  // coordinates on the host too (results), voxel size and origin
  uint32_t rows = 0, table_size = 0;
  std::unique_ptr<gpu::Buffer> ijk, kmap, table;
};

}  // namespace

struct VaeGpu::Impl {
  gpu::Context& ctx;
  VaeConfig config;
  kernels::nn::Conv3d conv1x1;
  kernels::nn::SparseConv3d sconv;
  kernels::nn::SparseKernelMap kmap;
  kernels::nn::SparseGridOps grid_ops;
  kernels::nn::GroupNorm gn;
  kernels::nn::Elementwise ew;
  std::map<std::string, std::unique_ptr<gpu::Buffer>> params;
  std::map<std::string, std::vector<int64_t>> shapes;
  uint64_t weight_bytes = 0;
  ActivationPool pool;  // activation memory plan (activation_pool.h)
  gpu::CommandList* cmd = nullptr;
  const Level* level = nullptr;
  std::vector<VaeGpu::Stage> stages;  // the last run's

  // Runs `fn` (host work and submissions) and books its wall time under `label` with the rows it covers.
  template <class F>
  void stage(const std::string& label, uint32_t rows, F&& fn) {
    const auto t0 = std::chrono::steady_clock::now();
    fn();
    stages.push_back({label, rows, std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count()});
  }
  template <class F>
  void submit(const std::string& label, uint32_t rows, F&& record) {
    stage(label, rows, [&] {
      ctx.submit_and_wait([&](gpu::CommandList& c) {
        cmd = &c;
        record();
      });
    });
  }

  Impl(gpu::Context& c, const VaeConfig& cfg)
      : ctx(c), config(cfg), conv1x1(c), sconv(c), kmap(c), grid_ops(c), gn(c), ew(c), pool(c, "vae-activation") {}

  const gpu::Buffer& P(const std::string& name) const {
    const auto it = params.find(name);
    if (it == params.end())
      throw std::invalid_argument("VaeGpu: the weights given have no '" + name + "' (encoding needs the encoder's, decoding the decoder's)");
    return *it->second;
  }
  bool has(const std::string& name) const { return params.count(name) != 0; }

  GT alloc(uint32_t channels, uint32_t rows) {
    GT t;
    t.channels = channels;
    t.rows = rows;
    t.buf = pool.take(std::max<uint64_t>(t.numel(), 1) * 4);
    return t;
  }
  void barrier() { cmd->barrier(gpu::deps::kComputeToCompute); }

  GT conv3(const GT& x, const std::string& name, bool silu = false) {
    const std::vector<int64_t>& ws = shapes.at(name + ".weight");
    GT y = alloc(static_cast<uint32_t>(ws[0]), x.rows);
    const kernels::nn::SparseConvShape s{x.rows, x.channels, y.channels, silu};
    sconv.record(*cmd, s, *x.buf, *level->kmap, P(name + ".weight"), has(name + ".bias") ? &P(name + ".bias") : nullptr, *y.buf);
    barrier();
    return y;
  }
  GT conv1(const GT& x, const std::string& name) {  // 1x1x1: Conv3d kernel 1 over 1 x 1 x rows
    const std::vector<int64_t>& ws = shapes.at(name + ".weight");
    GT y = alloc(static_cast<uint32_t>(ws[0]), x.rows);
    kernels::nn::Conv3dShape s;
    s.in_channels = x.channels;
    s.out_channels = y.channels;
    s.x = s.y = 1;
    s.z = x.rows;
    s.kernel = 1;
    conv1x1.record(*cmd, s, *x.buf, P(name + ".weight"), &P(name + ".bias"), *y.buf);
    barrier();
    return y;
  }
  GT group_norm(const GT& x, const std::string& name) {
    GT y = alloc(x.channels, x.rows);
    kernels::nn::GroupNormShape s;
    s.channels = x.channels;
    s.groups = x.channels < static_cast<uint32_t>(config.num_groups) ? 1u : static_cast<uint32_t>(config.num_groups);
    s.spatial = x.rows;
    s.eps = 1e-5f;
    GT scratch = alloc(static_cast<uint32_t>(kernels::nn::GroupNorm::scratch_bytes(s) / 4 + 1), 1);
    gn.record(*cmd, s, *x.buf, P(name + ".weight"), P(name + ".bias"), nullptr, *scratch.buf, *y.buf);
    barrier();
    return y;
  }
  GT silu(const GT& x) {
    GT y = alloc(x.channels, x.rows);
    ew.silu(*cmd, *x.buf, x.numel(), *y.buf);
    barrier();
    return y;
  }
  GT add(const GT& a, const GT& b) {
    GT y = alloc(a.channels, a.rows);
    ew.add(*cmd, *a.buf, *b.buf, a.numel(), *y.buf);
    barrier();
    return y;
  }
  GT conv_block(const std::string& name, GT x) {
    const std::string& order = config.order;
    for (size_t i = 0; i < order.size(); ++i) {
      const char op = order[i];
      if (op == 'g') {
        x = group_norm(x, name + ".GroupNorm");
      } else if (op == 'c') {
        const bool fuse = i + 1 < order.size() && order[i + 1] == 's';  // conv then SiLU: one pass
        x = conv3(x, name + ".Conv", fuse);
        if (fuse) ++i;
      } else if (op == 's') {
        x = silu(x);
      } else if (op == 'r') {
        throw std::invalid_argument("VaeGpu: ConvBlock order 'r' (ReLU) is not implemented on the GPU");
      }
    }
    return x;
  }
  GT res_block(const std::string& name, const GT& x) {
    GT h = conv_block(name + ".conv2", conv_block(name + ".conv1", x));
    const GT skip = has(name + ".skip_connection.weight") ? conv1(x, name + ".skip_connection") : x;
    return add(h, skip);
  }
  GT head(const std::string& name, const GT& x) { return conv1(conv_block(name + ".SingleConv", x), name + ".OutConv"); }

  // Takes `ijk` as the level's coordinates and records its hash table and kernel map (with the barriers
  // they need) into `cmd`.
  void build_level(Level& l, std::unique_ptr<gpu::Buffer> ijk) {
    l.rows = static_cast<uint32_t>(l.host.size());
    l.ijk = std::move(ijk);
    if (l.rows == 0) return;
    l.table_size = kernels::nn::SparseKernelMap::table_size(l.rows);
    l.table = std::make_unique<gpu::Buffer>(ctx, uint64_t{l.table_size} * 4, gpu::MemoryUsage::DeviceLocal, "vae-hash");
    l.kmap = std::make_unique<gpu::Buffer>(ctx, uint64_t{l.rows} * 27 * 4, gpu::MemoryUsage::DeviceLocal, "vae-kmap");
    kmap.record_clear(*cmd, *l.table, l.table_size);
    cmd->barrier(gpu::deps::kTransferToCompute);
    kmap.record_insert(*cmd, l.rows, *l.ijk, *l.table, l.table_size);
    barrier();
    kmap.record_map(*cmd, l.rows, *l.ijk, *l.table, l.table_size, *l.kmap);
    barrier();
  }
  static std::vector<int32_t> flat(const SparseGrid& g) {
    std::vector<int32_t> v;
    v.reserve(g.ijk.size() * 3);
    for (const Ijk& c : g.ijk) v.insert(v.end(), c.begin(), c.end());
    return v;
  }
  void reset_pool() {
    pool.reset();
    stages.clear();
  }
  std::vector<float> embedding;  // encoder.semantic_embed_fn.weight [classes, dim], on the host
};

VaeGpu::VaeGpu(gpu::Context& ctx, const VaeConfig& config, const std::map<std::string, CpuTensor>& weights)
    : impl_(std::make_unique<Impl>(ctx, config)) {
  for (const ParamSpec& p : vae_param_specs(config, VaePart::All)) {
    const auto it = weights.find(p.name);
    if (it == weights.end()) continue;  // the other part's (P() names what a run misses)
    const CpuTensor& t = it->second;
    if (t.shape != p.shape) throw std::invalid_argument("VaeGpu: weight '" + p.name + "' has shape " + t.shape_text());
    if (p.name == "encoder.semantic_embed_fn.weight") {
      impl_->embedding = t.data;
      continue;
    }
    std::vector<float> data = t.data;
    if (t.rank() == 5 && t.dim(2) == 3)
      data = kernels::nn::pack_conv3d_weights(t.data, static_cast<uint32_t>(t.dim(0)), static_cast<uint32_t>(t.dim(1)), 3);
    else if (t.rank() == 2)  // 1x1x1 conv (out, in)
      data = kernels::nn::pack_conv3d_weights(t.data, static_cast<uint32_t>(t.dim(0)), static_cast<uint32_t>(t.dim(1)), 1);
    impl_->params[p.name] = std::make_unique<gpu::Buffer>(gpu::upload_vector(ctx, data, p.name));
    impl_->shapes[p.name] = t.shape;
    impl_->weight_bytes += data.size() * 4;
  }
}

VaeGpu::~VaeGpu() = default;

uint64_t VaeGpu::last_activation_bytes() const { return impl_->pool.bytes(); }
uint64_t VaeGpu::weight_bytes() const { return impl_->weight_bytes; }
const std::vector<VaeGpu::Stage>& VaeGpu::last_stages() const { return impl_->stages; }

VaeDecoded VaeGpu::decode(const SparseTensor& latent_in) {
  Impl& m = *impl_;
  const VaeConfig& cfg = m.config;
  const int nb = cfg.num_blocks;
  if (latent_in.channels != cfg.latent_channels())
    throw std::invalid_argument("VAE decode: latent has " + std::to_string(latent_in.channels) + " channels, the model " +
                                std::to_string(cfg.latent_channels()));
  m.reset_pool();
  // The latent in brick order, channel-major.
  Level level;
  level.host = latent_in.grid;
  const std::vector<int64_t> perm = sort_brick_order(level.host);
  const uint32_t n0 = static_cast<uint32_t>(level.host.size());
  std::vector<float> x_cm(static_cast<size_t>(latent_in.channels) * n0);
  for (uint32_t r = 0; r < n0; ++r)
    for (int64_t c = 0; c < latent_in.channels; ++c) x_cm[static_cast<size_t>(c) * n0 + r] = latent_in.row(perm[r])[c];
  const std::vector<int32_t> flat = Impl::flat(level.host);

  VaeDecoded out;
  out.levels.resize(static_cast<size_t>(nb));
  GT x;
  std::unique_ptr<gpu::Buffer> logits_buf;  // the last structure logits [2][rows]
  auto download_level = [&](int depth, const GT& logits) {
    VaeLevel& l = out.levels[static_cast<size_t>(depth)];
    l.grid = level.host;
    l.logits.assign(2 * size_t{logits.rows}, 0.0f);
    if (logits.rows == 0) return;
    const std::vector<float> cm = gpu::download_vector<float>(m.ctx, *logits.buf, 2 * size_t{logits.rows});
    for (uint32_t r = 0; r < logits.rows; ++r) {
      l.logits[2 * r] = cm[r];
      l.logits[2 * r + 1] = cm[logits.rows + r];
    }
  };
  auto kept = [&](const VaeLevel& l) {
    int64_t k = 0;
    for (size_t r = 0; r < l.logits.size() / 2; ++r) k += l.logits[2 * r] > l.logits[2 * r + 1];
    return k;
  };
  // Subdivides the current level by its structure logits into the next one (factor 1: pruning).
  auto next_level = [&](const GT& logits, const Ijk& f, const std::string& label) {
    kernels::nn::SparseGridOps::Children ch;
    m.stage(label + ": structure decision, children", level.rows,
            [&] { ch = m.grid_ops.subdivide(*level.ijk, level.rows, *logits.buf, f); });
    Level next;
    for (int d = 0; d < 3; ++d) {
      next.host.voxel_size[d] = level.host.voxel_size[d] / f[d];
      next.host.origin[d] = level.host.origin[d] - (f[d] - 1) * next.host.voxel_size[d] / 2.0;
    }
    const std::vector<int32_t> c = ch.rows ? gpu::download_vector<int32_t>(m.ctx, ch.ijk, size_t{ch.rows} * 3) : std::vector<int32_t>{};
    next.host.ijk.resize(ch.rows);
    for (uint32_t r = 0; r < ch.rows; ++r) next.host.ijk[r] = {c[3 * r], c[3 * r + 1], c[3 * r + 2]};
    GT y = m.alloc(x.channels, ch.rows);
    m.submit(label + ": feature copy, kernel map", ch.rows, [&] {
      m.grid_ops.record_gather_rows(*m.cmd, *x.buf, x.rows, x.channels, ch.parent, ch.rows, *y.buf);
      m.barrier();
      m.build_level(next, std::make_unique<gpu::Buffer>(std::move(ch.ijk)));
    });
    x = y;
    level = std::move(next);
    m.level = &level;
  };

  GT logits;
  GT in;
  in.channels = static_cast<uint32_t>(latent_in.channels);
  in.rows = n0;
  in.buf = std::make_shared<gpu::Buffer>(gpu::upload_vector(m.ctx, x_cm, "vae-latent"));
  m.submit("latent level: kernel map, post-KL blocks", n0, [&] {
    m.build_level(level, std::make_unique<gpu::Buffer>(gpu::upload_vector(m.ctx, flat, "vae-latent-ijk")));
    m.level = &level;
    x = m.res_block("unet.post_kl_bottleneck.post_kl_bottleneck_0", in);
    x = m.res_block("unet.post_kl_bottleneck.post_kl_bottleneck_1", x);
  });
  for (int depth = nb - 1; depth >= 0; --depth) {
    const std::string idx = std::to_string(depth - nb);
    if (depth < nb - 1) next_level(logits, cfg.subdivide_factor(depth), "depth " + std::to_string(depth));
    m.submit("depth " + std::to_string(depth) + ": blocks, structure head", x.rows, [&] {
      if (depth < nb - 1)
        for (int b = 0; b <= cfg.num_res_blocks; ++b)
          if (x.rows) x = m.res_block("unet.decoders.Dec" + idx + "." + std::to_string(b), x);
      logits = x.rows ? m.head("unet.struct_convs.Struct" + idx, x) : m.alloc(2, 0);
    });
    download_level(depth, logits);
    if (kept(out.levels[static_cast<size_t>(depth)]) == 0 && out.warning.empty())
      out.warning = "the structure head at depth " + std::to_string(depth) + " kept no voxel: the chunk decodes empty";
  }
  next_level(logits, {1, 1, 1}, "pruning");
  out.semantic.grid = level.host;
  out.semantic.channels = cfg.num_semantic_classes;
  if (x.rows == 0) return out;
  GT sem;
  m.submit("semantic head", x.rows, [&] { sem = m.head("unet.semantic_head", x); });
  const std::vector<float> cm = gpu::download_vector<float>(m.ctx, *sem.buf, sem.numel());
  out.semantic.data.resize(cm.size());
  for (uint32_t r = 0; r < sem.rows; ++r)
    for (uint32_t c = 0; c < sem.channels; ++c) out.semantic.data[size_t{r} * sem.channels + c] = cm[size_t{c} * sem.rows + r];
  return out;
}

SparseTensor VaeGpu::encode(const SparseGrid& fine_in, const std::vector<int32_t>& classes_in) {
  Impl& m = *impl_;
  const VaeConfig& cfg = m.config;
  if (static_cast<int64_t>(classes_in.size()) != fine_in.size())
    throw std::invalid_argument("VAE encode: " + std::to_string(classes_in.size()) + " classes for " +
                                std::to_string(fine_in.size()) + " voxels");
  if (m.embedding.empty()) throw std::invalid_argument("VaeGpu: the weights given have no encoder (encoder.semantic_embed_fn.weight)");
  m.reset_pool();
  Level level;
  level.host = fine_in;
  const std::vector<int64_t> perm = sort_brick_order(level.host);
  const uint32_t n = static_cast<uint32_t>(level.host.size());
  if (n == 0) throw std::invalid_argument("VAE encode: the chunk has no voxels");
  for (const Ijk& c : level.host.ijk)
    for (const int32_t v : c)
      if (v <= -(1 << 19) || v >= (1 << 19)) throw std::invalid_argument("VAE encode: voxel coordinate " + std::to_string(v) + " is too far out (|ijk| < 2^19)");
  // Input features [65][n]: position embedding of the voxel centres, then the class embedding.
  const int pe = 3 + 6 * cfg.pos_freqs, dim = cfg.encoder_input_dim();
  std::vector<float> feats(static_cast<size_t>(dim) * n);
  for (uint32_t r = 0; r < n; ++r) {
    std::array<float, 3> p{};
    for (int d = 0; d < 3; ++d)
      p[static_cast<size_t>(d)] = static_cast<float>(level.host.ijk[r][static_cast<size_t>(d)]) *
                                      static_cast<float>(level.host.voxel_size[static_cast<size_t>(d)]) +
                                  static_cast<float>(level.host.origin[static_cast<size_t>(d)]);
    const std::vector<float> e = position_embedding(p, cfg.pos_freqs);
    for (int k = 0; k < pe; ++k) feats[static_cast<size_t>(k) * n + r] = e[static_cast<size_t>(k)];
    const int32_t cls = classes_in[static_cast<size_t>(perm[r])];
    if (cls < 0 || cls >= cfg.num_semantic)
      throw std::invalid_argument("VAE encode: class " + std::to_string(cls) + " is outside [0, " + std::to_string(cfg.num_semantic) + ")");
    for (int k = 0; k < cfg.dim_semantic; ++k)
      feats[static_cast<size_t>(pe + k) * n + r] = m.embedding[static_cast<size_t>(cls) * cfg.dim_semantic + static_cast<size_t>(k)];
  }
  GT in;
  in.channels = static_cast<uint32_t>(dim);
  in.rows = n;
  in.buf = std::make_shared<gpu::Buffer>(gpu::upload_vector(m.ctx, feats, "vae-encoder-input"));
  feats = {};
  GT x;
  m.submit("fine level: kernel map, mix_fc, pre_conv", n, [&] {
    m.build_level(level, std::make_unique<gpu::Buffer>(gpu::upload_vector(m.ctx, Impl::flat(level.host), "vae-fine-ijk")));
    m.level = &level;
    x = m.conv1(m.conv1(in, "encoder.mix_fc"), "unet.pre_conv");
  });
  in = {};
  for (int l = 0; l < cfg.num_blocks; ++l)
    for (int b = 0; b < cfg.num_res_blocks; ++b) {
      if (l > 0 && b == 0) {  // max pooling onto the coarsened grid
        const Ijk f = cfg.pool_factor(l);
        kernels::nn::SparseGridOps::Coarse coarse;
        m.stage("level " + std::to_string(l) + ": coarsened grid", level.rows,
                [&] { coarse = m.grid_ops.coarsen(*level.ijk, level.rows, f); });
        Level next;
        for (int d = 0; d < 3; ++d) {
          next.host.voxel_size[d] = level.host.voxel_size[d] * f[d];
          next.host.origin[d] = level.host.origin[d] + (f[d] - 1) * level.host.voxel_size[d] / 2.0;
        }
        const std::vector<int32_t> c = gpu::download_vector<int32_t>(m.ctx, coarse.ijk, size_t{coarse.rows} * 3);
        next.host.ijk.resize(coarse.rows);
        for (uint32_t r = 0; r < coarse.rows; ++r) next.host.ijk[r] = {c[3 * r], c[3 * r + 1], c[3 * r + 2]};
        GT y = m.alloc(x.channels, coarse.rows);
        m.submit("level " + std::to_string(l) + ": max pooling, kernel map", coarse.rows, [&] {
          m.grid_ops.record_max_pool(*m.cmd, coarse, *x.buf, x.channels, *y.buf);
          m.barrier();
          m.build_level(next, std::make_unique<gpu::Buffer>(std::move(coarse.ijk)));
        });
        x = y;
        level = std::move(next);
        m.level = &level;
      }
      m.submit("level " + std::to_string(l) + ": encoder block " + std::to_string(b), x.rows,
               [&] { x = m.res_block("unet.encoders.Enc" + std::to_string(l) + "-Block" + std::to_string(b), x); });
    }
  if (cfg.neck_dense) {  // the dense neck box [-b, b) at the latent level, zeros where the chunk has no voxel
    const Ijk& b = cfg.neck_bound;
    Level box;
    box.host = dense_box_grid({-b[0], -b[1], -b[2]}, {2 * b[0], 2 * b[1], 2 * b[2]}, level.host.voxel_size, level.host.origin);
    const uint32_t nb = static_cast<uint32_t>(box.host.size());
    gpu::Buffer query = gpu::upload_vector(m.ctx, Impl::flat(box.host), "vae-neck-ijk");
    gpu::Buffer rows(m.ctx, uint64_t{nb} * 4, gpu::MemoryUsage::DeviceLocal, "vae-neck-rows");
    GT y = m.alloc(x.channels, nb);
    m.submit("neck: dense box, kernel map", nb, [&] {
      m.grid_ops.record_lookup(*m.cmd, level.rows, *level.ijk, *level.table, level.table_size, nb, query, rows);
      m.barrier();
      m.grid_ops.record_gather_rows(*m.cmd, *x.buf, level.rows, x.channels, rows, nb, *y.buf);
      m.barrier();
      m.build_level(box, std::make_unique<gpu::Buffer>(std::move(query)));
    });
    x = y;
    level = std::move(box);
    m.level = &level;
  }
  GT moments;
  m.submit("pre-KL blocks, moments", x.rows, [&] {
    x = m.res_block("unet.pre_kl_bottleneck.pre_kl_bottleneck_0", x);
    x = m.res_block("unet.pre_kl_bottleneck.pre_kl_bottleneck_1", x);
    x = m.group_norm(x, "unet.pre_kl_bottleneck.pre_kl_bottleneck_gn.module");
    moments = m.conv3(x, "unet.pre_kl_bottleneck.pre_kl_bottleneck_2.module");
  });
  SparseTensor mu;
  mu.grid = level.host;
  mu.channels = cfg.latent_channels();
  const std::vector<float> cm = gpu::download_vector<float>(m.ctx, *moments.buf, size_t{static_cast<uint32_t>(mu.channels)} * moments.rows);
  mu.data.resize(cm.size());
  for (uint32_t r = 0; r < moments.rows; ++r)
    for (int64_t c = 0; c < mu.channels; ++c) mu.data[r * static_cast<size_t>(mu.channels) + static_cast<size_t>(c)] = cm[static_cast<size_t>(c) * moments.rows + r];
  return mu;
}

}  // namespace icube::nn

// The structure VAE decoder on the GPU; see vae_gpu.h.
#include "nn/vae_gpu.h"

#include "nn/layer_recorder.h"
#include "nn/parameter_store.h"
#include "kernels/nn/sparse_conv.h"
#include "kernels/nn/sparse_grid.h"

#include <chrono>
#include <stdexcept>

namespace icube::nn {

namespace {

using GT = DeviceTensor;  // sparse features: [1, channels, rows]

uint32_t rows_of(const GT& t) { return static_cast<uint32_t>(t.spatial()); }
uint32_t channels_of(const GT& t) { return static_cast<uint32_t>(t.channels()); }

// A level's grid on the device: coordinates and the 3^3 kernel map (built once, used by every conv there).
struct Level {
  SparseGrid host;  // coordinates on the host too (results), voxel size and origin
  uint32_t rows = 0, table_size = 0;
  std::unique_ptr<gpu::Buffer> ijk, kmap, table;
};

ParameterStoreOptions store_options(VaeGpu::Precision precision) {
  ParameterStoreOptions o;
  o.f16_matrices = f16_weights(precision);
  o.network = "the VAE";
  o.partial = true;  // the encoder's or the decoder's weights alone
  o.missing_hint = "encoding needs the encoder's weights, decoding the decoder's";
  o.host_only = {"encoder.semantic_embed_fn.weight"};
  return o;
}

}  // namespace

struct VaeGpu::Impl {
  gpu::Context& ctx;
  VaeConfig config;
  ParameterStore params;
  LayerRecorder L;
  kernels::nn::SparseKernelMap kmap;
  kernels::nn::SparseGridOps grid_ops;
  const Level* level = nullptr;
  std::vector<VaeGpu::Stage> stages;  // the last run's

  Impl(gpu::Context& c, const VaeConfig& cfg, const std::map<std::string, CpuTensor>& weights, VaeGpu::Precision precision)
      : ctx(c),
        config(cfg),
        params(c, vae_param_specs(cfg, VaePart::All), weights, store_options(precision)),
        L(c, params, "vae-activation"),
        kmap(c),
        grid_ops(c) {
    L.set_f16_conv_operands(f16_conv_operands(precision));
  }

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
        L.begin(c);
        record();
        L.end();
      });
    });
  }
  gpu::CommandList& cmd() const { return L.cmd(); }
  GT alloc(uint32_t channels, uint32_t rows) { return L.alloc({1, channels, rows}); }

  // The VAE's GroupNorm: num_groups groups, one where a tensor has fewer channels.
  uint32_t group_count(const GT& x) const {
    const uint32_t groups = static_cast<uint32_t>(config.num_groups);
    return channels_of(x) < groups ? 1u : groups;
  }
  GT conv_block(const std::string& name, GT x) {
    const std::string& order = config.order;
    for (size_t i = 0; i < order.size(); ++i) {
      const char op = order[i];
      if (op == 'g') {
        // Its output is a convolution's operand (fp16 under Precision::F16) only when the convolution comes next.
        const bool conv_next = i + 1 < order.size() && order[i + 1] == 'c';
        x = L.group_norm(x, name + ".GroupNorm", {group_count(x), 1e-5f, false, nullptr, !conv_next});
      } else if (op == 'c') {
        const bool fuse = i + 1 < order.size() && order[i + 1] == 's';  // conv then SiLU: one pass
        x = L.sparse_conv(x, name + ".Conv", *level->kmap, fuse);
        if (fuse) ++i;
      } else if (op == 's') {
        x = L.silu(x);
      } else if (op == 'r') {
        throw std::invalid_argument("VaeGpu: ConvBlock order 'r' (ReLU) is not implemented on the GPU");
      }
    }
    return x;
  }
  GT res_block(const std::string& name, const GT& x) {
    GT h = conv_block(name + ".conv2", conv_block(name + ".conv1", x));
    const GT skip = params.has(name + ".skip_connection.weight") ? L.conv(x, name + ".skip_connection") : x;
    return L.add(h, skip);
  }
  GT head(const std::string& name, const GT& x) { return L.conv(conv_block(name + ".SingleConv", x), name + ".OutConv"); }

  // Takes `ijk` as the level's coordinates and records its hash table and kernel map (with the barriers
  // they need) into `cmd`.
  void build_level(Level& l, std::unique_ptr<gpu::Buffer> ijk) {
    l.rows = static_cast<uint32_t>(l.host.size());
    l.ijk = std::move(ijk);
    if (l.rows == 0) return;
    l.table_size = kernels::nn::SparseKernelMap::table_size(l.rows);
    l.table = std::make_unique<gpu::Buffer>(ctx, uint64_t{l.table_size} * 4, gpu::MemoryUsage::DeviceLocal, "vae-hash");
    l.kmap = std::make_unique<gpu::Buffer>(ctx, uint64_t{l.rows} * 27 * 4, gpu::MemoryUsage::DeviceLocal, "vae-kmap");
    kmap.record_clear(cmd(), *l.table, l.table_size);
    cmd().barrier(gpu::deps::kTransferToCompute);
    kmap.record_insert(cmd(), l.rows, *l.ijk, *l.table, l.table_size);
    L.barrier();
    kmap.record_map(cmd(), l.rows, *l.ijk, *l.table, l.table_size, *l.kmap);
    L.barrier();
  }
  static std::vector<int32_t> flat(const SparseGrid& g) {
    std::vector<int32_t> v;
    v.reserve(g.ijk.size() * 3);
    for (const Ijk& c : g.ijk) v.insert(v.end(), c.begin(), c.end());
    return v;
  }
  void reset_pool() {
    L.pool().reset();
    stages.clear();
  }
};

VaeGpu::VaeGpu(gpu::Context& ctx, const VaeConfig& config, const std::map<std::string, CpuTensor>& weights,
               Precision precision)
    : impl_(std::make_unique<Impl>(ctx, config, weights, precision)) {}

VaeGpu::~VaeGpu() = default;

uint64_t VaeGpu::last_activation_bytes() const { return impl_->L.pool().bytes(); }
uint64_t VaeGpu::weight_bytes() const { return impl_->params.device_bytes(); }
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
    l.logits.assign(2 * size_t{rows_of(logits)}, 0.0f);
    if (rows_of(logits) == 0) return;
    const std::vector<float> cm = gpu::download_vector<float>(m.ctx, *logits.buf, 2 * size_t{rows_of(logits)});
    for (uint32_t r = 0; r < rows_of(logits); ++r) {
      l.logits[2 * r] = cm[r];
      l.logits[2 * r + 1] = cm[rows_of(logits) + r];
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
    GT y = m.alloc(channels_of(x), ch.rows);
    m.submit(label + ": feature copy, kernel map", ch.rows, [&] {
      m.grid_ops.record_gather_rows(m.cmd(), *x.buf, rows_of(x), channels_of(x), ch.parent, ch.rows, *y.buf);
      m.L.barrier();
      m.build_level(next, std::make_unique<gpu::Buffer>(std::move(ch.ijk)));
    });
    x = y;
    level = std::move(next);
    m.level = &level;
  };

  GT logits;
  const GT in{std::make_shared<gpu::Buffer>(gpu::upload_vector(m.ctx, x_cm, "vae-latent")), {1, latent_in.channels, n0}};
  m.submit("latent level: kernel map, post-KL blocks", n0, [&] {
    m.build_level(level, std::make_unique<gpu::Buffer>(gpu::upload_vector(m.ctx, flat, "vae-latent-ijk")));
    m.level = &level;
    x = m.res_block("unet.post_kl_bottleneck.post_kl_bottleneck_0", in);
    x = m.res_block("unet.post_kl_bottleneck.post_kl_bottleneck_1", x);
  });
  for (int depth = nb - 1; depth >= 0; --depth) {
    const std::string idx = std::to_string(depth - nb);
    if (depth < nb - 1) next_level(logits, cfg.subdivide_factor(depth), "depth " + std::to_string(depth));
    m.submit("depth " + std::to_string(depth) + ": blocks, structure head", rows_of(x), [&] {
      if (depth < nb - 1)
        for (int b = 0; b <= cfg.num_res_blocks; ++b)
          if (rows_of(x)) x = m.res_block("unet.decoders.Dec" + idx + "." + std::to_string(b), x);
      logits = rows_of(x) ? m.head("unet.struct_convs.Struct" + idx, x) : m.alloc(2, 0);
    });
    download_level(depth, logits);
    if (kept(out.levels[static_cast<size_t>(depth)]) == 0 && out.warning.empty())
      out.warning = "the structure head at depth " + std::to_string(depth) + " kept no voxel: the chunk decodes empty";
  }
  next_level(logits, {1, 1, 1}, "pruning");
  out.semantic.grid = level.host;
  out.semantic.channels = cfg.num_semantic_classes;
  if (rows_of(x) == 0) return out;
  GT sem;
  m.submit("semantic head", rows_of(x), [&] { sem = m.head("unet.semantic_head", x); });
  const std::vector<float> cm = gpu::download_vector<float>(m.ctx, *sem.buf, sem.numel());
  out.semantic.data.resize(cm.size());
  const uint32_t sem_rows = rows_of(sem), sem_channels = channels_of(sem);
  for (uint32_t r = 0; r < sem_rows; ++r)
    for (uint32_t c = 0; c < sem_channels; ++c) out.semantic.data[size_t{r} * sem_channels + c] = cm[size_t{c} * sem_rows + r];
  return out;
}

SparseTensor VaeGpu::encode(const SparseGrid& fine_in, const std::vector<int32_t>& classes_in) {
  Impl& m = *impl_;
  const VaeConfig& cfg = m.config;
  if (static_cast<int64_t>(classes_in.size()) != fine_in.size())
    throw std::invalid_argument("VAE encode: " + std::to_string(classes_in.size()) + " classes for " +
                                std::to_string(fine_in.size()) + " voxels");
  const std::vector<float>& embedding = m.params.host("encoder.semantic_embed_fn.weight").data;
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
      feats[static_cast<size_t>(pe + k) * n + r] = embedding[static_cast<size_t>(cls) * cfg.dim_semantic + static_cast<size_t>(k)];
  }
  GT in{std::make_shared<gpu::Buffer>(gpu::upload_vector(m.ctx, feats, "vae-encoder-input")), {1, dim, n}};
  feats = {};
  GT x;
  m.submit("fine level: kernel map, mix_fc, pre_conv", n, [&] {
    m.build_level(level, std::make_unique<gpu::Buffer>(gpu::upload_vector(m.ctx, Impl::flat(level.host), "vae-fine-ijk")));
    m.level = &level;
    x = m.L.conv(m.L.conv(in, "encoder.mix_fc"), "unet.pre_conv");
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
        GT y = m.alloc(channels_of(x), coarse.rows);
        m.submit("level " + std::to_string(l) + ": max pooling, kernel map", coarse.rows, [&] {
          m.grid_ops.record_max_pool(m.cmd(), coarse, *x.buf, channels_of(x), *y.buf);
          m.L.barrier();
          m.build_level(next, std::make_unique<gpu::Buffer>(std::move(coarse.ijk)));
        });
        x = y;
        level = std::move(next);
        m.level = &level;
      }
      m.submit("level " + std::to_string(l) + ": encoder block " + std::to_string(b), rows_of(x),
               [&] { x = m.res_block("unet.encoders.Enc" + std::to_string(l) + "-Block" + std::to_string(b), x); });
    }
  if (cfg.neck_dense) {  // the dense neck box [-b, b) at the latent level, zeros where the chunk has no voxel
    const Ijk& b = cfg.neck_bound;
    Level box;
    box.host = dense_box_grid({-b[0], -b[1], -b[2]}, {2 * b[0], 2 * b[1], 2 * b[2]}, level.host.voxel_size, level.host.origin);
    const uint32_t nb = static_cast<uint32_t>(box.host.size());
    gpu::Buffer query = gpu::upload_vector(m.ctx, Impl::flat(box.host), "vae-neck-ijk");
    gpu::Buffer rows(m.ctx, uint64_t{nb} * 4, gpu::MemoryUsage::DeviceLocal, "vae-neck-rows");
    GT y = m.alloc(channels_of(x), nb);
    m.submit("neck: dense box, kernel map", nb, [&] {
      m.grid_ops.record_lookup(m.cmd(), level.rows, *level.ijk, *level.table, level.table_size, nb, query, rows);
      m.L.barrier();
      m.grid_ops.record_gather_rows(m.cmd(), *x.buf, level.rows, channels_of(x), rows, nb, *y.buf);
      m.L.barrier();
      m.build_level(box, std::make_unique<gpu::Buffer>(std::move(query)));
    });
    x = y;
    level = std::move(box);
    m.level = &level;
  }
  GT moments;
  m.submit("pre-KL blocks, moments", rows_of(x), [&] {
    x = m.res_block("unet.pre_kl_bottleneck.pre_kl_bottleneck_0", x);
    x = m.res_block("unet.pre_kl_bottleneck.pre_kl_bottleneck_1", x);
    x = m.L.group_norm(x, "unet.pre_kl_bottleneck.pre_kl_bottleneck_gn.module", {m.group_count(x), 1e-5f});
    moments = m.L.sparse_conv(x, "unet.pre_kl_bottleneck.pre_kl_bottleneck_2.module", *level.kmap, false);
  });
  SparseTensor mu;
  mu.grid = level.host;
  mu.channels = cfg.latent_channels();
  const uint32_t rows = rows_of(moments);
  const std::vector<float> cm = gpu::download_vector<float>(m.ctx, *moments.buf, size_t{static_cast<uint32_t>(mu.channels)} * rows);
  mu.data.resize(cm.size());
  for (uint32_t r = 0; r < rows; ++r)
    for (int64_t c = 0; c < mu.channels; ++c) mu.data[r * static_cast<size_t>(mu.channels) + static_cast<size_t>(c)] = cm[static_cast<size_t>(c) * rows + r];
  return mu;
}

}  // namespace icube::nn

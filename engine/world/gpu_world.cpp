// Building, uploading and probing the GPU world.
#include "world/gpu_world.h"

#include "gpu/commands.h"

#include <algorithm>
#include <bit>
#include <cstddef>
#include <stdexcept>

namespace icube::world {

static_assert(WORLD_BRICK_BIAS == kBrickCoordBias, "world_layout.h and voxel_grid.h disagree on the brick bias");
static_assert(WORLD_MAX_IJK == kMaxIjk, "world_layout.h and voxel_grid.h disagree on the ijk range");
static_assert(sizeof(shader::WorldBrickRecord) == WORLD_BRICK_UINTS * 4, "brick record size");
static_assert(offsetof(shader::WorldBrickRecord, classes) == WORLD_CLASS_OFFSET * 4, "class offset");
static_assert(offsetof(shader::WorldBrickRecord, instances) == WORLD_INSTANCE_OFFSET * 4, "instance offset");

namespace {

uint32_t slot_hash(const glm::ivec3& b) {
  return shader::world_brick_hash(static_cast<uint32_t>(b.x + kBrickCoordBias), static_cast<uint32_t>(b.y + kBrickCoordBias),
                                  static_cast<uint32_t>(b.z + kBrickCoordBias));
}

}  // namespace

GpuWorldHost build_gpu_world_host(const VoxelGrid& grid) {
  GpuWorldHost h;
  const size_t n = grid.brick_count();
  if (n > (size_t{1} << 30)) throw std::length_error("GPU world: too many bricks");
  const uint64_t capacity = std::bit_ceil(std::max<uint64_t>(2, 2 * static_cast<uint64_t>(n)));
  h.table.assign(capacity, shader::WorldHashEntry{0, 0, WORLD_EMPTY_SLOT, 0});
  h.table_mask = static_cast<uint32_t>(capacity - 1);
  h.brick_count = static_cast<uint32_t>(n);
  h.bricks.assign(std::max<size_t>(n, 1) * WORLD_BRICK_UINTS, 0u);
  uint32_t out = 0;
  for (uint32_t bi : grid.sorted_brick_order()) {
    const Brick& b = grid.bricks()[bi];
    const uint64_t key = brick_key(b.coord);
    uint32_t slot = slot_hash(b.coord) & h.table_mask;
    while (h.table[slot].brick != WORLD_EMPTY_SLOT) slot = (slot + 1) & h.table_mask;
    h.table[slot] = {static_cast<uint32_t>(key), static_cast<uint32_t>(key >> 32), out, 0};
    write_brick_record(b, h.bricks.data() + static_cast<size_t>(out) * WORLD_BRICK_UINTS);
    ++out;
  }
  return h;
}

void write_brick_record(const Brick& b, uint32_t* rec) {
  std::fill(rec, rec + WORLD_BRICK_UINTS, 0u);
  for (size_t w = 0; w < 8; ++w) {
    rec[WORLD_MASK_OFFSET + 2 * w] = static_cast<uint32_t>(b.mask[w]);
    rec[WORLD_MASK_OFFSET + 2 * w + 1] = static_cast<uint32_t>(b.mask[w] >> 32);
  }
  for (uint32_t v = 0; v < kBrickVoxels; ++v) {
    rec[WORLD_CLASS_OFFSET + v / 4] |= static_cast<uint32_t>(b.classes[v]) << (8 * (v % 4));
    rec[WORLD_INSTANCE_OFFSET + v / 2] |= static_cast<uint32_t>(b.instances[v]) << (16 * (v % 2));
  }
}

uint32_t brick_key_hash(uint64_t key) {
  return shader::world_brick_hash(static_cast<uint32_t>(key & kBrickAxisMask),
                                  static_cast<uint32_t>((key >> 21) & kBrickAxisMask),
                                  static_cast<uint32_t>((key >> 42) & kBrickAxisMask));
}

bool table_entry_is(const shader::WorldHashEntry& e, uint64_t key) {
  return e.brick != WORLD_EMPTY_SLOT && e.key_lo == static_cast<uint32_t>(key) &&
         e.key_hi == static_cast<uint32_t>(key >> 32);
}

void record_set_voxel(uint32_t* rec, const glm::ivec3& ijk, uint8_t cls, uint16_t inst) {
  const uint32_t n = static_cast<uint32_t>(voxel_bit(ijk));
  rec[WORLD_MASK_OFFSET + n / 32] |= 1u << (n % 32);
  uint32_t& c = rec[WORLD_CLASS_OFFSET + n / 4];
  c = (c & ~(0xffu << (8 * (n % 4)))) | (uint32_t{cls} << (8 * (n % 4)));
  uint32_t& i = rec[WORLD_INSTANCE_OFFSET + n / 2];
  i = (i & ~(0xffffu << (16 * (n % 2)))) | (uint32_t{inst} << (16 * (n % 2)));
}

Voxel record_voxel(const uint32_t* rec, const glm::ivec3& ijk) {
  const uint32_t n = static_cast<uint32_t>(voxel_bit(ijk));
  if (!((rec[WORLD_MASK_OFFSET + n / 32] >> (n % 32)) & 1u)) return {};
  return {static_cast<uint8_t>(rec[WORLD_CLASS_OFFSET + n / 4] >> (8 * (n % 4))),
          static_cast<uint16_t>(rec[WORLD_INSTANCE_OFFSET + n / 2] >> (16 * (n % 2)))};
}

uint32_t find_table_slot(const std::vector<shader::WorldHashEntry>& table, uint32_t mask, uint64_t key) {
  uint32_t s = brick_key_hash(key) & mask;
  while (table[s].brick != WORLD_EMPTY_SLOT && !table_entry_is(table[s], key)) s = (s + 1) & mask;
  return s;
}

void join_brick_bounds(IjkBounds& b, uint64_t key) {
  const glm::ivec3 lo = brick_from_key(key) * kBrickDim;
  const glm::ivec3 hi = lo + glm::ivec3(kBrickDim - 1);
  if (b.empty()) {
    b = {lo, hi};
  } else {
    b.min = glm::min(b.min, lo);
    b.max = glm::max(b.max, hi);
  }
}

Voxel lookup_gpu_world_host(const GpuWorldHost& h, const glm::ivec3& ijk) {
  if (!ijk_in_range(ijk)) return {};
  const glm::ivec3 bc = brick_of(ijk);
  const uint64_t key = brick_key(bc);
  uint32_t slot = slot_hash(bc) & h.table_mask;
  for (uint32_t probe = 0; probe <= h.table_mask; ++probe) {
    const shader::WorldHashEntry& e = h.table[slot];
    if (e.brick == WORLD_EMPTY_SLOT) return {};
    if (table_entry_is(e, key)) return record_voxel(h.bricks.data() + static_cast<size_t>(e.brick) * WORLD_BRICK_UINTS, ijk);
    slot = (slot + 1) & h.table_mask;
  }
  return {};
}

GpuWorld upload_gpu_world(gpu::Context& ctx, const VoxelGrid& grid) {
  const GpuWorldHost h = build_gpu_world_host(grid);
  GpuWorld w;
  w.brick_table = gpu::upload_vector(ctx, h.table, "world-brick-table");
  w.brick_data = gpu::upload_vector(ctx, h.bricks, "world-brick-data");
  w.table_mask = h.table_mask;
  w.brick_count = h.brick_count;
  w.origin = grid.origin();
  w.voxel_size = grid.voxel_size();
  return w;
}

std::vector<Voxel> probe_gpu_world(gpu::Context& ctx, const GpuWorld& world, const std::vector<glm::ivec3>& queries) {
  if (queries.empty()) return {};
  if (queries.size() > UINT32_MAX) throw std::invalid_argument("probe_gpu_world: too many queries");
  std::vector<glm::ivec4> q;
  q.reserve(queries.size());
  for (const glm::ivec3& v : queries) q.emplace_back(v, 0);
  gpu::Buffer qbuf = gpu::upload_vector(ctx, q, "world-probe-queries");
  gpu::Buffer rbuf(ctx, queries.size() * 8, gpu::MemoryUsage::DeviceLocal, "world-probe-results");
  gpu::Program& prog = ctx.program("world/probe");
  const shader::WorldProbeParams params{static_cast<uint32_t>(queries.size()), world.table_mask, 0, 0};
  ctx.submit_and_wait([&](gpu::CommandList& cmd) {
    cmd.dispatch(prog, {queries.size()}, params,
                 {world.brick_table.binding(), world.brick_data.binding(), qbuf.binding(), rbuf.binding()});
  });
  const std::vector<glm::uvec2> r = gpu::download_vector<glm::uvec2>(ctx, rbuf, queries.size());
  std::vector<Voxel> out(r.size());
  for (size_t i = 0; i < r.size(); ++i) out[i] = {static_cast<uint8_t>(r[i].x), static_cast<uint16_t>(r[i].y)};
  return out;
}

}  // namespace icube::world

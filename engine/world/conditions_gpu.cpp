// GPU host module for the Stage-1 condition volume; see conditions_gpu.h.
#include "world/conditions_gpu.h"

#include "shared/conditions_params.h"

#include <stdexcept>

namespace icube::world {

namespace {

constexpr uint64_t kVolumeBytes = kCondChannels * kCondVoxels * sizeof(float);

gpu::Program& subgroup_program(gpu::Context& ctx, const char* name) {
  return ctx.program(name, gpu::SpecConstants{}.set(0, ctx.subgroup_size() /* local_size_x */));
}

void push_vec4(std::vector<float>& out, const glm::dvec3& v, double w) {
  out.insert(out.end(), {static_cast<float>(v.x), static_cast<float>(v.y), static_cast<float>(v.z), static_cast<float>(w)});
}

}  // namespace

static_assert(kLatentDim == COND_DIM, "shader grid size differs from kLatentDim");

std::vector<float> pack_boxes(const std::vector<ChunkBox>& boxes) {
  std::vector<float> out;
  out.reserve(boxes.size() * COND_BOX_VEC4S * 4);
  for (const ChunkBox& b : boxes) {
    const AxisBox bounds = box_bounds(b.box);
    // Degenerate boxes get zero extents: the kernel's clipping then yields 0.
    const bool ok = b.box.size.x > 0.0 && b.box.size.y > 0.0 && b.box.size.z > 0.0;
    const glm::dvec3 half = ok ? b.box.size * 0.5 : glm::dvec3(0.0);
    push_vec4(out, b.box.center, half.x * half.y * half.z * 8.0);
    push_vec4(out, half, 0.0);
    for (int k = 0; k < 3; ++k) push_vec4(out, b.box.axes[k], 0.0);
    push_vec4(out, bounds.lo, b.sin_heading);
    push_vec4(out, bounds.hi, b.cos_heading);
  }
  return out;
}

ConditionVolumeGpu::ConditionVolumeGpu(gpu::Context& ctx)
    : ctx_(ctx), points_(subgroup_program(ctx, "world/cond_points")), boxes_(subgroup_program(ctx, "world/cond_boxes")) {}

ConditionBuffers ConditionVolumeGpu::upload_inputs(const ConditionInputs& in) {
  ConditionBuffers b;
  std::vector<float> pts;
  pts.reserve((in.edge_grid.size() + in.line_grid.size() + in.surface_grid.size()) * 3);
  for (const auto* v : {&in.edge_grid, &in.line_grid, &in.surface_grid})
    for (const glm::vec3& q : *v) pts.insert(pts.end(), {q.x, q.y, q.z});
  if (pts.size() / 3 > UINT32_MAX || in.boxes.size() > UINT32_MAX / COND_BOX_VEC4S)
    throw std::invalid_argument("conditions: too many points or boxes");
  b.edge_count = static_cast<uint32_t>(in.edge_grid.size());
  b.line_count = static_cast<uint32_t>(in.line_grid.size());
  b.surface_count = static_cast<uint32_t>(in.surface_grid.size());
  b.box_count = static_cast<uint32_t>(in.boxes.size());
  b.points = gpu::upload_vector(ctx_, pts, "cond-points");
  b.boxes = gpu::upload_vector(ctx_, pack_boxes(in.boxes), "cond-boxes");
  return b;
}

void ConditionVolumeGpu::record(gpu::CommandList& cmd, const ConditionBuffers& in, const gpu::Buffer& volume) {
  if (volume.size() < kVolumeBytes) throw std::invalid_argument("conditions: volume buffer too small");
  cmd.fill_buffer(volume.binding(0, kVolumeBytes), 0u);
  cmd.barrier(gpu::deps::kTransferToCompute);  // both kernels overwrite parts of the zero fill
  const shader::CondBoxesParams bp{in.box_count, static_cast<float>(kBoxOccupancyFraction * kLatentCellVolume),
                                   kGpuCoplanarCos, kGpuCoplanarDist};
  cmd.dispatch(boxes_, {kCondVoxels}, bp, {in.boxes.binding(), volume.binding(0, kVolumeBytes)});
  // cond_points writes channels 3-5 only, disjoint from cond_boxes: no barrier between them.
  uint64_t first = 0;
  const std::pair<uint32_t, uint32_t> runs[] = {
      {in.edge_count, kCondRoadEdge}, {in.line_count, kCondRoadLine}, {in.surface_count, kCondRoadSurface}};
  for (const auto& [count, channel] : runs) {
    if (count > 0) {
      const shader::CondPointsParams pp{count, channel, static_cast<uint32_t>(first), 0};
      cmd.dispatch(points_, {count}, pp, {in.points.binding(), volume.binding(0, kVolumeBytes)});
    }
    first += count;
  }
}

std::vector<float> ConditionVolumeGpu::build(const ConditionInputs& in) {
  ConditionBuffers b = upload_inputs(in);
  gpu::Buffer volume(ctx_, kVolumeBytes, gpu::MemoryUsage::DeviceLocal, "cond-volume");
  ctx_.submit_and_wait([&](gpu::CommandList& cmd) { record(cmd, b, volume); });
  return gpu::download_vector<float>(ctx_, volume, kCondChannels * kCondVoxels);
}

}  // namespace icube::world

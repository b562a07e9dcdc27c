// A network's parameters on the device; see parameter_store.h.
#include "nn/parameter_store.h"

#include "kernels/nn/conv2d.h"
#include "kernels/nn/conv3d.h"
#include "scene/input_error.h"

namespace icube::nn {

void ParameterStore::fail(const std::string& name, const std::string& what) const {
  throw scene::InputError(options_.source, "tensor '" + scene::printable(name, 120) + "'", options_.network + ": " + what);
}

ParameterStore::ParameterStore(gpu::Context& ctx, const std::vector<ParamSpec>& specs,
                               const std::map<std::string, CpuTensor>& weights, ParameterStoreOptions options)
    : options_(std::move(options)) {
  for (const ParamSpec& p : specs) {
    const auto it = weights.find(p.name);
    if (it == weights.end()) {
      if (options_.partial) continue;
      fail(p.name, "missing (needs shape " + shape_text(p.shape) + ")");
    }
    const CpuTensor& t = it->second;
    if (t.shape != p.shape) fail(p.name, "has shape " + shape_text(t.shape) + ", needs " + shape_text(p.shape));
    if (t.data.size() != static_cast<size_t>(t.numel())) fail(p.name, "holds " + std::to_string(t.data.size()) + " values for shape " + shape_text(t.shape));
    Entry e;
    e.shape = p.shape;
    if (options_.host_only.count(p.name)) {
      e.host = t;
    } else if (p.shape.size() == 4) {
      // A 2-D convolution [Co, Ci, kh, kw]: conv2d's packing, fp32 (the 2-D kernel has no fp16 path).
      e.device = std::make_unique<gpu::Buffer>(gpu::upload_vector(
          ctx,
          kernels::nn::pack_conv2d_weights(t.data, static_cast<uint32_t>(p.shape[0]), static_cast<uint32_t>(p.shape[1]),
                                           static_cast<uint32_t>(p.shape[2]), static_cast<uint32_t>(p.shape[3])),
          p.name));
    } else if (is_matrix(p.shape)) {
      const auto co = static_cast<uint32_t>(p.shape[0]), ci = static_cast<uint32_t>(p.shape[1]);
      const uint32_t k = kernel_edge(p.shape);
      e.device = std::make_unique<gpu::Buffer>(
          options_.f16_matrices ? gpu::upload_vector(ctx, kernels::nn::pack_conv3d_weights_f16(t.data, co, ci, k), p.name)
                                : gpu::upload_vector(ctx, kernels::nn::pack_conv3d_weights(t.data, co, ci, k), p.name));
    } else {
      e.device = std::make_unique<gpu::Buffer>(gpu::upload_vector(ctx, t.data, p.name));
    }
    if (e.device) device_bytes_ += e.device->size();
    entries_.emplace(p.name, std::move(e));
  }
}

const ParameterStore::Entry& ParameterStore::entry(const std::string& name) const {
  const auto it = entries_.find(name);
  if (it == entries_.end())
    fail(name, "the weights have no such tensor" + (options_.missing_hint.empty() ? std::string() : " (" + options_.missing_hint + ")"));
  return it->second;
}

const gpu::Buffer& ParameterStore::buffer(const std::string& name) const {
  const Entry& e = entry(name);
  if (!e.device) fail(name, "is kept on the host, not on the device");
  return *e.device;
}

const std::vector<int64_t>& ParameterStore::shape(const std::string& name) const { return entry(name).shape; }

const CpuTensor& ParameterStore::host(const std::string& name) const {
  const Entry& e = entry(name);
  if (e.device) fail(name, "is on the device, not kept on the host");
  return e.host;
}

}  // namespace icube::nn

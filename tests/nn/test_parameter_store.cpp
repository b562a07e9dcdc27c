// The networks' parameter store (engine/nn/parameter_store.h): matrices packed
// as the conv kernels read them (fp32 and fp16, checked against the packers on
// the bytes read back), vectors as given, host-only tensors kept on the host,
// and every weight error a scene::InputError naming the source and the tensor.
// Validation on.
#include <doctest/doctest.h>

#include "gpu_test_context.h"
#include "kernels/nn/conv3d.h"
#include "nn/parameter_store.h"
#include "scene/input_error.h"

#include <random>

using namespace icube;

namespace {

const std::vector<nn::ParamSpec> kSpecs = {
    {"block.conv.weight", {5, 3, 3, 3, 3}},  // 3^3 convolution
    {"block.conv.bias", {5}},
    {"block.proj.weight", {7, 5}},      // linear
    {"block.qkv.weight", {6, 5, 1}},    // Conv1d kernel 1
    {"embed.weight", {4, 2}},           // an embedding table, kept on the host
    {"block.norm.weight", {5}},
};

std::map<std::string, nn::CpuTensor> random_weights(uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<float> nd(0.0f, 1.0f);
  std::map<std::string, nn::CpuTensor> w;
  for (const nn::ParamSpec& p : kSpecs) {
    nn::CpuTensor t(p.shape);
    for (float& f : t.data) f = nd(rng);
    w.emplace(p.name, std::move(t));
  }
  return w;
}

nn::ParameterStoreOptions options(bool f16) {
  nn::ParameterStoreOptions o;
  o.network = "the test network";
  o.source = "weights.safetensors";
  o.f16_matrices = f16;
  o.host_only = {"embed.weight"};
  return o;
}

template <class T>
std::vector<T> read_back(const gpu::Buffer& b) {
  return gpu::download_vector<T>(test::gpu_context(), b, b.size() / sizeof(T));
}

std::string message_of(const std::function<void()>& fn) {
  try {
    fn();
  } catch (const scene::InputError& e) {
    return e.what();
  }
  return "(no scene::InputError)";
}

}  // namespace

TEST_CASE("parameter store: matrices packed for the conv kernels in fp32 and fp16, vectors as given") {
  const auto w = random_weights(3);
  for (const bool f16 : {false, true}) {
    CAPTURE(f16);
    const nn::ParameterStore store(test::gpu_context(), kSpecs, w, options(f16));
    uint64_t bytes = 0;
    for (const auto& [name, shape] : std::map<std::string, std::pair<uint32_t, uint32_t>>{
             {"block.conv.weight", {5, 3}}, {"block.proj.weight", {7, 5}}, {"block.qkv.weight", {6, 5}}}) {
      CAPTURE(name);
      const uint32_t k = nn::ParameterStore::kernel_edge(store.shape(name));
      CHECK(k == (name == "block.conv.weight" ? 3u : 1u));
      const auto& data = w.at(name).data;
      if (f16)
        CHECK(read_back<uint16_t>(store.buffer(name)) == kernels::nn::pack_conv3d_weights_f16(data, shape.first, shape.second, k));
      else
        CHECK(read_back<float>(store.buffer(name)) == kernels::nn::pack_conv3d_weights(data, shape.first, shape.second, k));
      bytes += store.buffer(name).size();
    }
    CHECK(read_back<float>(store.buffer("block.conv.bias")) == w.at("block.conv.bias").data);
    CHECK(read_back<float>(store.buffer("block.norm.weight")) == w.at("block.norm.weight").data);
    bytes += store.buffer("block.conv.bias").size() + store.buffer("block.norm.weight").size();
    CHECK(store.device_bytes() == bytes);
    CHECK(store.host("embed.weight").data == w.at("embed.weight").data);
    CHECK(store.shape("embed.weight") == std::vector<int64_t>{4, 2});
  }
}

TEST_CASE("parameter store: weight errors name the source and the tensor") {
  auto w = random_weights(4);
  w.at("block.proj.weight") = nn::CpuTensor({5, 7});
  CHECK(message_of([&] { nn::ParameterStore(test::gpu_context(), kSpecs, w, options(false)); }) ==
        "weights.safetensors: tensor 'block.proj.weight': the test network: has shape [5, 7], needs [7, 5]");
  w = random_weights(4);
  w.erase("block.norm.weight");
  CHECK(message_of([&] { nn::ParameterStore(test::gpu_context(), kSpecs, w, options(false)); }) ==
        "weights.safetensors: tensor 'block.norm.weight': the test network: missing (needs shape [5])");
  // A network run in parts: absent parameters are refused when a layer looks them up.
  nn::ParameterStoreOptions o = options(false);
  o.partial = true;
  o.missing_hint = "the encoder needs the encoder's weights";
  const nn::ParameterStore part(test::gpu_context(), kSpecs, w, o);
  CHECK_FALSE(part.has("block.norm.weight"));
  CHECK(message_of([&] { (void)part.buffer("block.norm.weight"); }) ==
        "weights.safetensors: tensor 'block.norm.weight': the test network: the weights have no such tensor (the encoder "
        "needs the encoder's weights)");
  CHECK(message_of([&] { (void)part.buffer("embed.weight"); }).find("kept on the host") != std::string::npos);
  CHECK(message_of([&] { (void)part.host("block.conv.bias"); }).find("on the device") != std::string::npos);
}

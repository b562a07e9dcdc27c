// Tests of the SPIR-V reflection that checks every dispatch, and of the
// embedded shader table.
#include <doctest/doctest.h>

#include "gpu/shader_registry.h"
#include "gpu/spirv_reflect.h"

#include <stdexcept>
#include <vector>

using namespace icube::gpu;

TEST_CASE("every embedded shader reflects as a compute shader with set-0 bindings") {
  REQUIRE(kEmbeddedShaderCount >= 8);
  for (size_t i = 0; i < kEmbeddedShaderCount; ++i) {
    const EmbeddedShader& s = kEmbeddedShaders[i];
    CAPTURE(s.name);
    ShaderReflection r = reflect_spirv(s.words, s.word_count, s.name);
    for (const ReflectedBinding& b : r.bindings) CHECK(b.set == 0);
    CHECK(r.push_constant_size % 4 == 0);
    CHECK(r.push_constant_size <= 128);  // the smallest maxPushConstantsSize Vulkan allows
  }
}

TEST_CASE("reflection reads workgroup sizes, spec ids, bindings and push-constant sizes") {
  const EmbeddedShader& scan = find_shader("primitives/scan_tiles");
  ShaderReflection r = reflect_spirv(scan.words, scan.word_count, scan.name);
  CHECK(r.local_size_spec_id[0] == 0);  // layout(local_size_x_id = 0)
  CHECK(r.local_size_spec_id[1] == -1);
  CHECK(r.local_size[1] == 1);
  REQUIRE(r.bindings.size() == 3);
  CHECK(r.bindings[0].binding == 0);
  CHECK(r.bindings[2].binding == 2);
  CHECK(r.bindings[0].type == VK_DESCRIPTOR_TYPE_STORAGE_BUFFER);
  CHECK(r.push_constant_size == 16);
  CHECK(r.spec_ids == std::vector<uint32_t>{0, 1});

  const EmbeddedShader& iota = find_shader("primitives/iota");
  ShaderReflection ri = reflect_spirv(iota.words, iota.word_count, iota.name);
  CHECK(ri.local_size[0] == 64);  // literal layout(local_size_x = 64)
  CHECK(ri.local_size_spec_id[0] == -1);
  CHECK(ri.bindings.size() == 1);

  const EmbeddedShader& scatter = find_shader("primitives/radix_scatter64");
  CHECK(reflect_spirv(scatter.words, scatter.word_count, scatter.name).bindings.size() == 5);
}

TEST_CASE("malformed SPIR-V is rejected with the shader's name") {
  const EmbeddedShader& s = find_shader("primitives/iota");
  std::vector<uint32_t> words(s.words, s.words + s.word_count);
  std::vector<uint32_t> bad_magic = words;
  bad_magic[0] = 0xdeadbeef;
  CHECK_THROWS_WITH_AS(reflect_spirv(bad_magic.data(), bad_magic.size(), "broken"), doctest::Contains("broken"),
                       std::runtime_error);
  std::vector<uint32_t> truncated(words.begin(), words.begin() + 5);
  truncated.push_back((40u << 16) | 71u);  // an OpDecorate claiming 40 words
  CHECK_THROWS_WITH_AS(reflect_spirv(truncated.data(), truncated.size(), "cut"), doctest::Contains("truncated"),
                       std::runtime_error);
  CHECK_THROWS_AS(reflect_spirv(words.data(), 3, "tiny"), std::runtime_error);
}

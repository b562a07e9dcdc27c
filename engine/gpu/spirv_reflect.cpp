#include "gpu/spirv_reflect.h"

#include <algorithm>
#include <stdexcept>
#include <unordered_map>

namespace icube::gpu {
namespace {

// SPIR-V opcodes, decorations and enums used here (SPIR-V 1.6 specification).
enum Op : uint32_t {
  OpName = 5, OpEntryPoint = 15, OpExecutionMode = 16, OpTypeBool = 20, OpTypeInt = 21, OpTypeFloat = 22,
  OpTypeVector = 23, OpTypeMatrix = 24, OpTypeImage = 25, OpTypeSampler = 26, OpTypeSampledImage = 27,
  OpTypeArray = 28, OpTypeRuntimeArray = 29, OpTypeStruct = 30, OpTypePointer = 32, OpConstant = 43,
  OpSpecConstantTrue = 48, OpSpecConstantFalse = 49, OpSpecConstant = 50, OpSpecConstantComposite = 51,
  OpVariable = 59, OpDecorate = 71, OpMemberDecorate = 72, OpExecutionModeId = 331,
};
enum Decoration : uint32_t {
  DecSpecId = 1, DecBlock = 2, DecBufferBlock = 3, DecArrayStride = 6, DecBuiltIn = 11, DecBinding = 33,
  DecDescriptorSet = 34, DecOffset = 35,
};
constexpr uint32_t kBuiltInWorkgroupSize = 25;
constexpr uint32_t kModeLocalSize = 17, kModeLocalSizeId = 38;
constexpr uint32_t kStorageUniformConstant = 0, kStorageUniform = 2, kStoragePushConstant = 9,
                   kStorageStorageBuffer = 12;
constexpr uint32_t kExecModelGLCompute = 5;

struct TypeInfo {
  uint32_t op = 0;
  std::vector<uint32_t> operands;  // words after the result id
};

struct Module {
  std::unordered_map<uint32_t, TypeInfo> types;
  std::unordered_map<uint32_t, uint32_t> constants;  // id -> first literal word (OpConstant / OpSpecConstant)
  std::unordered_map<uint32_t, uint32_t> spec_id;    // id -> SpecId
  std::unordered_map<uint32_t, std::vector<uint32_t>> spec_composites;
  std::unordered_map<uint32_t, uint32_t> binding, set, array_stride;
  std::unordered_map<uint32_t, bool> block, buffer_block;
  std::unordered_map<uint64_t, uint32_t> member_offset;  // (struct << 32 | member) -> offset
  std::unordered_map<uint32_t, std::string> names;
  uint32_t workgroup_size_builtin = 0;
};

std::string literal_string(const uint32_t* w, size_t n) {
  std::string s;
  for (size_t i = 0; i < n; ++i)
    for (int b = 0; b < 4; ++b) {
      char c = static_cast<char>((w[i] >> (8 * b)) & 0xff);
      if (!c) return s;
      s.push_back(c);
    }
  return s;
}

uint32_t type_size(const Module& m, uint32_t id, const std::string& shader, int depth = 0) {
  if (depth > 32) throw std::runtime_error("SPIR-V reflection of " + shader + ": type nesting too deep");
  auto it = m.types.find(id);
  if (it == m.types.end()) throw std::runtime_error("SPIR-V reflection of " + shader + ": unknown type id");
  const TypeInfo& t = it->second;
  switch (t.op) {
    case OpTypeBool: return 4;
    case OpTypeInt:
    case OpTypeFloat: return t.operands.at(0) / 8;
    case OpTypeVector:
    case OpTypeMatrix: return type_size(m, t.operands.at(0), shader, depth + 1) * t.operands.at(1);
    case OpTypeArray: {
      auto len = m.constants.find(t.operands.at(1));
      if (len == m.constants.end()) throw std::runtime_error("SPIR-V reflection of " + shader + ": array length is not a constant");
      auto stride = m.array_stride.find(id);
      uint32_t elem = stride != m.array_stride.end() ? stride->second : type_size(m, t.operands.at(0), shader, depth + 1);
      return elem * len->second;
    }
    case OpTypeStruct: {
      uint32_t size = 0;
      for (uint32_t i = 0; i < t.operands.size(); ++i) {
        auto off = m.member_offset.find((uint64_t(id) << 32) | i);
        uint32_t o = off != m.member_offset.end() ? off->second : size;
        size = std::max(size, o + type_size(m, t.operands[i], shader, depth + 1));
      }
      return size;
    }
    default: throw std::runtime_error("SPIR-V reflection of " + shader + ": unsupported type in push constants");
  }
}

}  // namespace

ShaderReflection reflect_spirv(const uint32_t* words, size_t word_count, const std::string& name) {
  if (word_count < 5 || words[0] != 0x07230203u)
    throw std::runtime_error("SPIR-V reflection of " + name + ": not a SPIR-V module (bad magic)");
  Module m;
  ShaderReflection r;
  bool is_compute = false;
  struct Var {
    uint32_t id, pointer_type, storage;
  };
  std::vector<Var> vars;
  std::vector<uint32_t> local_size_ids;

  for (size_t pos = 5; pos < word_count;) {
    uint32_t count = words[pos] >> 16, op = words[pos] & 0xffff;
    if (count == 0 || pos + count > word_count)
      throw std::runtime_error("SPIR-V reflection of " + name + ": truncated instruction at word " + std::to_string(pos));
    const uint32_t* w = words + pos + 1;
    size_t n = count - 1;
    switch (op) {
      case OpName:
        m.names[w[0]] = literal_string(w + 1, n - 1);
        break;
      case OpEntryPoint:
        if (w[0] == kExecModelGLCompute) is_compute = true;
        break;
      case OpExecutionMode:
        if (w[1] == kModeLocalSize && n >= 5) r.local_size[0] = w[2], r.local_size[1] = w[3], r.local_size[2] = w[4];
        break;
      case OpExecutionModeId:
        if (w[1] == kModeLocalSizeId && n >= 5) local_size_ids = {w[2], w[3], w[4]};
        break;
      case OpTypeBool: case OpTypeInt: case OpTypeFloat: case OpTypeVector: case OpTypeMatrix: case OpTypeImage:
      case OpTypeSampler: case OpTypeSampledImage: case OpTypeArray: case OpTypeRuntimeArray: case OpTypeStruct:
      case OpTypePointer:
        m.types[w[0]] = TypeInfo{op, std::vector<uint32_t>(w + 1, w + n)};
        break;
      case OpConstant:
      case OpSpecConstant:
        if (n >= 3) m.constants[w[1]] = w[2];
        break;
      case OpSpecConstantTrue: m.constants[w[1]] = 1; break;
      case OpSpecConstantFalse: m.constants[w[1]] = 0; break;
      case OpSpecConstantComposite:
        m.spec_composites[w[1]] = std::vector<uint32_t>(w + 2, w + n);
        break;
      case OpVariable:
        vars.push_back({w[1], w[0], w[2]});
        break;
      case OpDecorate:
        switch (w[1]) {
          case DecSpecId: m.spec_id[w[0]] = w[2]; break;
          case DecBlock: m.block[w[0]] = true; break;
          case DecBufferBlock: m.buffer_block[w[0]] = true; break;
          case DecArrayStride: m.array_stride[w[0]] = w[2]; break;
          case DecBuiltIn: if (w[2] == kBuiltInWorkgroupSize) m.workgroup_size_builtin = w[0]; break;
          case DecBinding: m.binding[w[0]] = w[2]; break;
          case DecDescriptorSet: m.set[w[0]] = w[2]; break;
          default: break;
        }
        break;
      case OpMemberDecorate:
        if (w[2] == DecOffset) m.member_offset[(uint64_t(w[0]) << 32) | w[1]] = w[3];
        break;
      default: break;
    }
    pos += count;
  }
  if (!is_compute) throw std::runtime_error("SPIR-V reflection of " + name + ": no GLCompute entry point");

  for (const auto& [id, sid] : m.spec_id) r.spec_ids.push_back(sid);
  std::sort(r.spec_ids.begin(), r.spec_ids.end());
  r.spec_ids.erase(std::unique(r.spec_ids.begin(), r.spec_ids.end()), r.spec_ids.end());

  // Workgroup size: the WorkgroupSize built-in (a spec-constant composite when
  // local_size_x_id is used) overrides the execution mode.
  std::vector<uint32_t> comps = local_size_ids;
  if (m.workgroup_size_builtin && m.spec_composites.count(m.workgroup_size_builtin))
    comps = m.spec_composites[m.workgroup_size_builtin];
  for (size_t axis = 0; axis < comps.size() && axis < 3; ++axis) {
    uint32_t cid = comps[axis];
    if (m.constants.count(cid)) r.local_size[axis] = m.constants[cid];
    if (m.spec_id.count(cid)) r.local_size_spec_id[axis] = static_cast<int32_t>(m.spec_id[cid]);
  }

  for (const Var& v : vars) {
    const TypeInfo& ptr = m.types.at(v.pointer_type);
    uint32_t pointee = ptr.operands.at(1);
    // Arrays of descriptors are not used by the engine's kernels.
    if (v.storage == kStoragePushConstant) {
      r.push_constant_size = type_size(m, pointee, name);
      continue;
    }
    VkDescriptorType type;
    if (v.storage == kStorageStorageBuffer) {
      type = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    } else if (v.storage == kStorageUniform) {
      type = m.buffer_block.count(pointee) ? VK_DESCRIPTOR_TYPE_STORAGE_BUFFER : VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER;
    } else if (v.storage == kStorageUniformConstant) {
      const TypeInfo& t = m.types.at(pointee);
      // OpTypeImage operands: sampled type, Dim, Depth, Arrayed, MS, Sampled (1 sampled, 2 storage), format.
      constexpr uint32_t kDimBuffer = 5;
      if (t.op == OpTypeImage && t.operands.at(1) == kDimBuffer)
        type = t.operands.at(5) == 2 ? VK_DESCRIPTOR_TYPE_STORAGE_TEXEL_BUFFER : VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER;
      else if (t.op == OpTypeImage)
        type = t.operands.at(5) == 2 ? VK_DESCRIPTOR_TYPE_STORAGE_IMAGE : VK_DESCRIPTOR_TYPE_SAMPLED_IMAGE;
      else if (t.op == OpTypeSampledImage && m.types.at(t.operands.at(0)).operands.at(1) == kDimBuffer)
        type = VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER;  // samplerBuffer: a texel buffer, no sampler
      else if (t.op == OpTypeSampledImage)
        type = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
      else if (t.op == OpTypeSampler)
        type = VK_DESCRIPTOR_TYPE_SAMPLER;
      else
        continue;
    } else {
      continue;
    }
    ReflectedBinding b;
    b.set = m.set.count(v.id) ? m.set[v.id] : 0;
    b.binding = m.binding.count(v.id) ? m.binding[v.id] : 0;
    b.type = type;
    b.name = m.names.count(v.id) && !m.names[v.id].empty() ? m.names[v.id] : m.names[pointee];
    r.bindings.push_back(b);
  }
  std::sort(r.bindings.begin(), r.bindings.end(), [](const ReflectedBinding& a, const ReflectedBinding& b) {
    return a.set != b.set ? a.set < b.set : a.binding < b.binding;
  });
  for (const ReflectedBinding& b : r.bindings)
    if (b.set != 0)
      throw std::runtime_error("shader " + name + ": binding '" + b.name + "' uses descriptor set " +
                               std::to_string(b.set) + "; kernels use set 0 only");
  return r;
}

}  // namespace icube::gpu

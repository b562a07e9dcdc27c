// Bridge for structs shared between GLSL and C++ (push constants, GPU records).
// In C++ the structs live in namespace icube::shader and each header
// static_asserts its sizes and offsets, so the two sides cannot drift apart.
#ifndef ICUBE_GPU_TYPES_H
#define ICUBE_GPU_TYPES_H
#ifdef __cplusplus
#include <cstddef>
#include <cstdint>
#define ICUBE_SHADER_NAMESPACE_BEGIN namespace icube::shader { using uint = std::uint32_t;
#define ICUBE_SHADER_NAMESPACE_END }
#define ICUBE_CHECK_LAYOUT(type, member, offset) \
  static_assert(offsetof(icube::shader::type, member) == (offset), #type "." #member " offset differs from GLSL")
#define ICUBE_CHECK_SIZE(type, size) static_assert(sizeof(icube::shader::type) == (size), #type " size differs from GLSL")
#else
#define ICUBE_SHADER_NAMESPACE_BEGIN
#define ICUBE_SHADER_NAMESPACE_END
#define ICUBE_CHECK_LAYOUT(type, member, offset)
#define ICUBE_CHECK_SIZE(type, size)
#endif
#endif

// Vehicle meshes in the object frame (x forward, y left, z up); see vehicle_mesh.h.
#include "world/vehicle_mesh.h"

#include "scene/input_error.h"

#include <cmath>

namespace icube::world {
namespace {

glm::dvec3 unit(const SignedAxis& a) {
  glm::dvec3 v(0.0);
  v[a.axis] = a.negative ? -1.0 : 1.0;
  return v;
}

std::optional<SignedAxis> parse_axis(std::string_view s) {
  SignedAxis a;
  if (!s.empty() && (s[0] == '+' || s[0] == '-')) {
    a.negative = s[0] == '-';
    s.remove_prefix(1);
  }
  if (s.size() != 1 || s[0] < 'x' || s[0] > 'z') return std::nullopt;
  a.axis = s[0] - 'x';
  return a;
}

}  // namespace

MeshAxes default_mesh_axes(MeshFormat format) {
  if (format == MeshFormat::Gltf) return MeshAxes{{2, false}, {1, false}};
  return MeshAxes{};
}

std::optional<MeshAxes> parse_mesh_axes(std::string_view text) {
  const size_t comma = text.find(',');
  if (comma == std::string_view::npos) return std::nullopt;
  const auto f = parse_axis(text.substr(0, comma)), u = parse_axis(text.substr(comma + 1));
  if (!f || !u || f->axis == u->axis) return std::nullopt;
  return MeshAxes{*f, *u};
}

std::string mesh_axes_name(const MeshAxes& axes) {
  auto name = [](const SignedAxis& a) { return std::string(a.negative ? "-" : "+") + static_cast<char>('x' + a.axis); };
  return name(axes.forward) + "," + name(axes.up);
}

void orient_mesh(TriangleMesh& mesh, const MeshAxes& axes) {
  const glm::dvec3 f = unit(axes.forward), u = unit(axes.up), l = glm::cross(u, f);
  for (auto& p : mesh.positions) p = glm::dvec3(glm::dot(f, p), glm::dot(l, p), glm::dot(u, p));
}

VehicleMeshFile load_vehicle_mesh(const std::string& path, const std::optional<MeshAxes>& axes) {
  VehicleMeshFile out;
  out.mesh = load_mesh(path, &out.format);
  out.axes = axes ? *axes : default_mesh_axes(out.format);
  if (out.mesh.triangles.empty())
    throw scene::InputError(path, "mesh",
                            std::string("no triangles in this ") + mesh_format_name(out.format) + " file");
  orient_mesh(out.mesh, out.axes);
  const MeshBounds b = mesh_bounds(out.mesh);
  static const char* const kAxis[3] = {"length (forward)", "width (left)", "height (up)"};
  for (int k = 0; k < 3; ++k)
    if (!(b.max[k] - b.min[k] > 0.0))
      throw scene::InputError(path, "mesh",
                              std::string("no extent along its ") + kAxis[k] + " axis with axes " +
                                  mesh_axes_name(out.axes) + " (forward,up); a flat mesh cannot fill a box");
  return out;
}

}  // namespace icube::world

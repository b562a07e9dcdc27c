// Vehicle types by box length and their per-type JSON; see vehicle_mesh_set.h.
#include "world/vehicle_mesh_set.h"

#include "scene/atomic_file.h"
#include "scene/input_error.h"
#include "world/car_mesh.h"
#include "world/semantics.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>

namespace icube::world {
namespace {

using scene::InputError;

std::string metres(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

// "length": [min, max], 0 <= min < max, both finite.
void read_length(const nlohmann::json& j, const std::string& name, const std::string& key, VehicleType& t) {
  const bool ok = j.is_array() && j.size() == 2 && j[0].is_number() && j[1].is_number();
  const double lo = ok ? j[0].get<double>() : 0.0, hi = ok ? j[1].get<double>() : 0.0;
  if (!ok || !std::isfinite(lo) || !std::isfinite(hi) || lo < 0.0 || !(hi > lo))
    throw InputError(name, key + ".length", "must be [min, max] in metres with 0 <= min < max");
  t.min_length = lo;
  t.max_length = hi;
}

VehicleType read_type(const std::string& json_key, const nlohmann::json& j, const std::string& name,
                      const std::string& base_dir, bool several) {
  const auto cls = semantic_class_from_name(json_key);
  const std::string key = scene::printable(json_key, 40);  // for messages
  if (!cls || !is_vehicle_class(*cls))
    throw InputError(name, key, "unknown vehicle type (car, truck, bus, other_vehicle)");
  if (!j.is_object()) throw InputError(name, key, "must be an object {\"mesh\": FILE, \"length\": [min, max]}");
  for (const auto& [k, v] : j.items())
    if (k != "mesh" && k != "length" && k != "axes")
      throw InputError(name, key + "." + scene::printable(k, 40), "unknown key (mesh, length, axes)");
  VehicleType t;
  t.name = key;
  t.class_id = *cls;
  if (!j.contains("mesh") || !j["mesh"].is_string() || j["mesh"].get<std::string>().empty())
    throw InputError(name, key + ".mesh", "missing: the mesh file (PLY, OBJ or glTF) as a string");
  if (j.contains("axes")) {
    t.requested_axes = j["axes"].is_string() ? parse_mesh_axes(j["axes"].get<std::string>()) : std::nullopt;
    if (!t.requested_axes)
      throw InputError(name, key + ".axes", "must be \"FORWARD,UP\", each one of +x -x +y -y +z -z, e.g. \"+z,+y\"");
  }
  if (j.contains("length"))
    read_length(j["length"], name, key, t);
  else if (several)
    throw InputError(name, key + ".length", "missing: with several types each needs [min, max] in metres");
  const std::filesystem::path mesh(j["mesh"].get<std::string>());
  t.source = (mesh.is_absolute() || base_dir.empty() ? mesh : std::filesystem::path(base_dir) / mesh).string();
  return t;
}

}  // namespace

const VehicleType& VehicleMeshSet::pick(double length) const {
  for (const auto& t : types)
    if (length >= t.min_length && length < t.max_length) return t;
  const VehicleType* best = &types.front();
  double best_gap = std::numeric_limits<double>::infinity();
  for (const auto& t : types) {
    const double gap = length < t.min_length ? t.min_length - length : length - t.max_length;
    if (gap < best_gap) best = &t, best_gap = gap;  // strict: ties keep the shorter type
  }
  return *best;
}

VehicleMeshSet builtin_vehicle_meshes() {
  VehicleMeshSet s;
  VehicleType t;
  t.source = "built-in car";
  t.mesh = builtin_car_mesh();
  s.types.push_back(std::move(t));
  return s;
}

VehicleMeshSet single_vehicle_mesh(VehicleMeshFile file, const std::string& source) {
  VehicleMeshSet s;
  VehicleType t;
  t.source = source;
  t.requested_axes = t.axes = file.axes;
  t.mesh = std::move(file.mesh);
  s.types.push_back(std::move(t));
  return s;
}

VehicleMeshSet parse_vehicle_mesh_set(const std::string& text, const std::string& name, const std::string& base_dir) {
  nlohmann::json doc;
  try {
    doc = nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {
    std::string what = e.what();
    std::replace(what.begin(), what.end(), '\n', ' ');
    throw InputError(name, "", "not valid JSON: " + what);
  }
  if (!doc.is_object() || doc.empty())
    throw InputError(name, "", "expected an object of vehicle types, e.g. {\"car\": {\"mesh\": \"car.ply\"}}");
  VehicleMeshSet s;
  for (const auto& [key, value] : doc.items()) s.types.push_back(read_type(key, value, name, base_dir, doc.size() > 1));
  std::sort(s.types.begin(), s.types.end(),
            [](const VehicleType& a, const VehicleType& b) { return a.min_length < b.min_length; });
  for (size_t i = 1; i < s.types.size(); ++i)
    if (s.types[i].min_length < s.types[i - 1].max_length)
      throw InputError(name, s.types[i].name + ".length",
                       "[" + metres(s.types[i].min_length) + ", " + metres(s.types[i].max_length) + ") overlaps " +
                           s.types[i - 1].name + "'s [" + metres(s.types[i - 1].min_length) + ", " +
                           metres(s.types[i - 1].max_length) + ")");
  return s;
}

VehicleMeshSet load_vehicle_mesh_set(const std::string& json_path) {
  const std::string dir = std::filesystem::path(json_path).parent_path().string();
  VehicleMeshSet s = parse_vehicle_mesh_set(scene::read_file(json_path), json_path, dir);
  for (auto& t : s.types) {
    VehicleMeshFile f = load_vehicle_mesh(t.source, t.requested_axes);
    t.axes = f.axes;
    t.mesh = std::move(f.mesh);
  }
  return s;
}

}  // namespace icube::world

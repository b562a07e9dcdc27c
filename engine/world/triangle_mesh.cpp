// Mesh readers (PLY, OBJ, glTF/GLB) and the OBJ writer; see triangle_mesh.h.
// tinygltf's implementation lives in tinygltf_impl.cpp (same configuration macros).
#include "world/triangle_mesh.h"

#include "scene/atomic_file.h"
#include "scene/input_error.h"
#include "world/ply_reader.h"

#include "world/tinygltf_include.h"

#include <glm/gtc/quaternion.hpp>
#include <glm/gtc/type_ptr.hpp>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>

namespace icube::world {
namespace {

using scene::InputError;

bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\f' || c == '\v'; }

// Splits a line into whitespace-separated tokens.
std::vector<std::string_view> tokens_of(std::string_view line) {
  std::vector<std::string_view> out;
  size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && is_space(line[i])) ++i;
    size_t j = i;
    while (j < line.size() && !is_space(line[j])) ++j;
    if (j > i) out.push_back(line.substr(i, j - i));
    i = j;
  }
  return out;
}

bool parse_double(std::string_view s, double& out) {
  if (!s.empty() && s[0] == '+') s.remove_prefix(1);
  auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), out);
  return ec == std::errc() && p == s.data() + s.size();
}

bool parse_int(std::string_view s, int64_t& out) {
  if (!s.empty() && s[0] == '+') s.remove_prefix(1);
  auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), out);
  return ec == std::errc() && p == s.data() + s.size();
}

std::string quoted(std::string_view s) { return "'" + std::string(s.substr(0, 40)) + "'"; }

void check_indices(const TriangleMesh& m, const std::string& name, const char* what) {
  const size_t n = m.positions.size();
  for (size_t t = 0; t < m.triangles.size(); ++t)
    for (int k = 0; k < 3; ++k)
      if (m.triangles[t][k] >= n)
        throw InputError(name, std::string(what) + " " + std::to_string(t),
                         "vertex index " + std::to_string(m.triangles[t][k]) + " out of range (" +
                             std::to_string(n) + " vertices)");
}

// ---- PLY (header and values from world/ply_reader.h) ---------------------------

// Reads the body's values with the mesh reader's messages: "<element> <i>[ (line N)]: ...".
class MeshPlyBody {
 public:
  MeshPlyBody(const PlyHeader& h, std::string_view bytes, const std::string& name)
      : in_(bytes.substr(h.body_offset), h.format, h.body_offset, h.header_lines + 1), name_(name) {}

  double read(PlyType t, const std::string& where) {
    double v = 0.0;
    switch (in_.next(t, v)) {
      case PlyCursor::Status::Ok: return v;
      case PlyCursor::Status::End: throw InputError(name_, where + line_note(), "file ends early");
      case PlyCursor::Status::BadInteger: throw InputError(name_, where + line_note(), "bad integer " + quoted(in_.token()));
      case PlyCursor::Status::BadNumber: break;
    }
    throw InputError(name_, where + line_note(), "bad number " + quoted(in_.token()));
  }
  // " (line N)" for ascii bodies, "" for binary ones.
  std::string line_note() const { return in_.ascii() ? " (line " + std::to_string(in_.line()) + ")" : ""; }
  const std::string& name() const { return name_; }

 private:
  PlyCursor in_;
  const std::string& name_;
};

// One face list: validated indices fanned into triangles.
void read_face_list(MeshPlyBody& body, const PlyProperty& p, double n, bool have_vertex, TriangleMesh& mesh,
                    const std::string& where, std::vector<uint32_t>& poly) {
  const std::string& name = body.name();
  if (n < 3) throw InputError(name, where + body.line_note(), "face with " + std::to_string(static_cast<int>(n)) + " vertices");
  poly.clear();
  for (uint64_t j = 0; j < static_cast<uint64_t>(n); ++j) {
    const double id = body.read(p.type, where);
    if (!ply_type_is_int(p.type) || id < 0 || id > static_cast<double>(std::numeric_limits<uint32_t>::max()))
      throw InputError(name, where + body.line_note(), "bad vertex index " + std::to_string(id));
    if (have_vertex && id >= static_cast<double>(mesh.positions.size()))
      throw InputError(name, where + body.line_note(),
                       "vertex index " + std::to_string(static_cast<uint64_t>(id)) + " out of range (" +
                           std::to_string(mesh.positions.size()) + " vertices)");
    poly.push_back(static_cast<uint32_t>(id));
  }
  for (size_t j = 1; j + 1 < poly.size(); ++j) mesh.triangles.push_back({poly[0], poly[j], poly[j + 1]});
}

// The columns the mesh reader uses in one element (-1: absent or not this element).
struct MeshColumns {
  bool is_vertex = false, is_face = false;
  int xyz[3] = {-1, -1, -1};
  int idx = -1;
};

MeshColumns mesh_columns(const PlyElement& e, const std::string& name) {
  MeshColumns c;
  c.is_vertex = e.name == "vertex";
  c.is_face = e.name == "face";
  for (size_t k = 0; k < e.props.size(); ++k) {
    const auto& p = e.props[k];
    if (c.is_vertex && !p.is_list && p.name.size() == 1 && p.name[0] >= 'x' && p.name[0] <= 'z')
      c.xyz[p.name[0] - 'x'] = static_cast<int>(k);
    if (c.is_face && p.is_list && (p.name == "vertex_indices" || p.name == "vertex_index")) c.idx = static_cast<int>(k);
  }
  if (c.is_vertex && (c.xyz[0] < 0 || c.xyz[1] < 0 || c.xyz[2] < 0))
    throw InputError(name, "element vertex", "no x, y, z properties");
  if (c.is_face && c.idx < 0) throw InputError(name, "element face", "no vertex_indices list");
  return c;
}

// Reads every row of one element into the mesh (vertices, faces) or skips it.
void read_mesh_element(MeshPlyBody& body, const PlyElement& e, const MeshColumns& c, bool have_vertex,
                       TriangleMesh& mesh) {
  std::vector<uint32_t> poly;
  for (uint64_t i = 0; i < e.count; ++i) {
    const std::string where = e.name + " " + std::to_string(i);
    glm::dvec3 v(0.0);
    for (size_t k = 0; k < e.props.size(); ++k) {
      const auto& p = e.props[k];
      if (!p.is_list) {
        const double value = body.read(p.type, where);
        for (int a = 0; a < 3; ++a)
          if (c.is_vertex && c.xyz[a] == static_cast<int>(k)) v[a] = value;
        continue;
      }
      const double n = body.read(p.count_type, where);
      if (n < 0) throw InputError(body.name(), where + body.line_note(), "negative list length");
      if (c.is_face && static_cast<int>(k) == c.idx) {
        read_face_list(body, p, n, have_vertex, mesh, where, poly);
        continue;
      }
      for (uint64_t j = 0; j < static_cast<uint64_t>(n); ++j) body.read(p.type, where);
    }
    if (c.is_vertex) {
      if (!std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z))
        throw InputError(body.name(), where + body.line_note(), "coordinate is not finite");
      mesh.positions.push_back(v);
    }
  }
}

}  // namespace

TriangleMesh parse_ply(std::string_view bytes, const std::string& name) {
  const PlyHeader h = parse_ply_header(bytes, name);
  // The smallest possible size of each element instance bounds the counts before anything is allocated.
  for (const auto& e : h.elements)
    if (!ply_rows_fit(e, h.format, bytes.size() - h.body_offset))
      throw InputError(name, "element " + e.name, std::to_string(e.count) + " entries cannot fit in the file");
  TriangleMesh mesh;
  MeshPlyBody body(h, bytes, name);
  bool have_vertex = false, have_face = false;
  for (const auto& e : h.elements) {
    const MeshColumns c = mesh_columns(e, name);
    if (c.is_vertex) {
      have_vertex = true;
      mesh.positions.reserve(e.count);
    }
    if (c.is_face) {
      have_face = true;
      mesh.triangles.reserve(e.count);
    }
    if (e.props.empty()) continue;  // nothing to read, however large the count
    read_mesh_element(body, e, c, have_vertex, mesh);
  }
  if (!have_vertex) throw InputError(name, "header", "no vertex element");
  if (!have_face) throw InputError(name, "header", "no face element");
  check_indices(mesh, name, "triangle");
  return mesh;
}

// ---- OBJ ----------------------------------------------------------------------

TriangleMesh parse_obj(std::string_view text, const std::string& name) {
  TriangleMesh mesh;
  size_t pos = 0, line_no = 0;
  std::vector<uint32_t> poly;
  while (pos < text.size()) {
    size_t nl = text.find('\n', pos);
    if (nl == std::string_view::npos) nl = text.size();
    std::string_view line = text.substr(pos, nl - pos);
    pos = nl + 1;
    ++line_no;
    if (const size_t hash = line.find('#'); hash != std::string_view::npos) line = line.substr(0, hash);
    const auto tok = tokens_of(line);
    if (tok.empty()) continue;
    const std::string where = "line " + std::to_string(line_no);
    if (tok[0] == "v") {
      if (tok.size() < 4) throw InputError(name, where, "vertex needs x y z");
      glm::dvec3 v;
      for (int a = 0; a < 3; ++a)
        if (!parse_double(tok[1 + a], v[a]) || !std::isfinite(v[a]))
          throw InputError(name, where, "bad coordinate " + quoted(tok[1 + a]));
      mesh.positions.push_back(v);
    } else if (tok[0] == "f") {
      if (tok.size() < 4) throw InputError(name, where, "face needs at least 3 vertices");
      poly.clear();
      const int64_t n = static_cast<int64_t>(mesh.positions.size());
      for (size_t k = 1; k < tok.size(); ++k) {
        const std::string_view ref = tok[k].substr(0, tok[k].find('/'));
        int64_t id = 0;
        if (!parse_int(ref, id) || id == 0) throw InputError(name, where, "bad vertex reference " + quoted(tok[k]));
        const int64_t resolved = id < 0 ? n + id : id - 1;
        if (resolved < 0 || resolved >= n)
          throw InputError(name, where, "vertex reference " + std::to_string(id) + " out of range (" +
                                            std::to_string(n) + " vertices so far)");
        poly.push_back(static_cast<uint32_t>(resolved));
      }
      for (size_t j = 1; j + 1 < poly.size(); ++j) mesh.triangles.push_back({poly[0], poly[j], poly[j + 1]});
    }
  }
  return mesh;
}

// ---- glTF ---------------------------------------------------------------------

namespace {

bool ignore_image(tinygltf::Image*, const int, std::string*, std::string*, int, int, const unsigned char*, int, void*) {
  return true;  // geometry only: images are neither decoded nor required
}

struct GltfReader {
  const tinygltf::Model& model;
  const std::string& name;
  TriangleMesh& mesh;

  // Start of element 0, stride and count of an accessor, bounds-checked.
  const unsigned char* accessor_data(int index, int want_type, const std::vector<int>& components, size_t& stride,
                                     size_t& count, const std::string& where) const {
    if (index < 0 || index >= static_cast<int>(model.accessors.size()))
      throw InputError(name, where, "accessor " + std::to_string(index) + " does not exist");
    const auto& acc = model.accessors[static_cast<size_t>(index)];
    const std::string aw = where + " accessor " + std::to_string(index);
    if (acc.sparse.isSparse) throw InputError(name, aw, "sparse accessors are not supported");
    if (acc.type != want_type || std::find(components.begin(), components.end(), acc.componentType) == components.end())
      throw InputError(name, aw, "unsupported type/component type");
    if (acc.bufferView < 0 || acc.bufferView >= static_cast<int>(model.bufferViews.size()))
      throw InputError(name, aw, "no valid buffer view");
    const auto& bv = model.bufferViews[static_cast<size_t>(acc.bufferView)];
    if (bv.buffer < 0 || bv.buffer >= static_cast<int>(model.buffers.size()))
      throw InputError(name, aw, "no valid buffer");
    const auto& buf = model.buffers[static_cast<size_t>(bv.buffer)].data;
    const int s = acc.ByteStride(bv);
    if (s <= 0) throw InputError(name, aw, "bad byte stride");
    const size_t elem = static_cast<size_t>(tinygltf::GetComponentSizeInBytes(static_cast<uint32_t>(acc.componentType)) *
                                            tinygltf::GetNumComponentsInType(static_cast<uint32_t>(acc.type)));
    stride = static_cast<size_t>(s);
    count = acc.count;
    if (count > 0 && count - 1 > buf.size() / stride) throw InputError(name, aw, "count runs past its buffer");
    const size_t start = bv.byteOffset + acc.byteOffset;
    const size_t need = count == 0 ? 0 : stride * (count - 1) + elem;
    if (start > buf.size() || need > buf.size() - start || acc.byteOffset + need > bv.byteLength)
      throw InputError(name, aw, "data runs past its buffer view or buffer");
    return buf.data() + start;
  }

  // One POSITION element: float, or integers (KHR_mesh_quantization), normalized to [0, 1] / [-1, 1] when flagged.
  static glm::dvec3 position(const unsigned char* e, int component, bool normalized) {
    glm::dvec3 v(0.0);
    for (int k = 0; k < 3; ++k) {
      switch (component) {
        case TINYGLTF_COMPONENT_TYPE_FLOAT: {
          float f;
          std::memcpy(&f, e + 4 * k, 4);
          v[k] = static_cast<double>(f);
          break;
        }
        case TINYGLTF_COMPONENT_TYPE_BYTE: {
          const auto b = static_cast<int8_t>(e[k]);
          v[k] = normalized ? std::max(b / 127.0, -1.0) : b;
          break;
        }
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: v[k] = normalized ? e[k] / 255.0 : e[k]; break;
        case TINYGLTF_COMPONENT_TYPE_SHORT: {
          int16_t h;
          std::memcpy(&h, e + 2 * k, 2);
          v[k] = normalized ? std::max(h / 32767.0, -1.0) : h;
          break;
        }
        default: {
          uint16_t h;
          std::memcpy(&h, e + 2 * k, 2);
          v[k] = normalized ? h / 65535.0 : h;
          break;
        }
      }
    }
    return v;
  }

  void add_primitive(const tinygltf::Primitive& prim, const glm::dmat4& xf, const std::string& where) {
    const int mode = prim.mode < 0 ? TINYGLTF_MODE_TRIANGLES : prim.mode;
    if (mode != TINYGLTF_MODE_TRIANGLES && mode != TINYGLTF_MODE_TRIANGLE_STRIP && mode != TINYGLTF_MODE_TRIANGLE_FAN)
      return;  // points and lines have no surface
    const auto it = prim.attributes.find("POSITION");
    if (it == prim.attributes.end()) throw InputError(name, where, "no POSITION attribute");
    size_t stride = 0, count = 0;
    const unsigned char* p = accessor_data(
        it->second, TINYGLTF_TYPE_VEC3,
        {TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_COMPONENT_TYPE_BYTE, TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE,
         TINYGLTF_COMPONENT_TYPE_SHORT, TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT},
        stride, count, where);
    const auto& acc = model.accessors[static_cast<size_t>(it->second)];
    const uint32_t base = static_cast<uint32_t>(mesh.positions.size());
    for (size_t i = 0; i < count; ++i) {
      const glm::dvec3 v = position(p + i * stride, acc.componentType, acc.normalized);
      const glm::dvec4 w = xf * glm::dvec4(v, 1.0);
      if (!std::isfinite(w.x) || !std::isfinite(w.y) || !std::isfinite(w.z))
        throw InputError(name, where, "position " + std::to_string(i) + " is not finite");
      mesh.positions.emplace_back(w);
    }
    std::vector<uint32_t> idx;
    if (prim.indices >= 0) {
      size_t is = 0, ic = 0;
      const unsigned char* q = accessor_data(prim.indices, TINYGLTF_TYPE_SCALAR,
                                             {TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE, TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT,
                                              TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT},
                                             is, ic, where + " indices");
      const int ct = model.accessors[static_cast<size_t>(prim.indices)].componentType;
      idx.resize(ic);
      for (size_t i = 0; i < ic; ++i) {
        const unsigned char* e = q + i * is;
        if (ct == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE) idx[i] = e[0];
        else if (ct == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT) { uint16_t v; std::memcpy(&v, e, 2); idx[i] = v; }
        else std::memcpy(&idx[i], e, 4);
        if (idx[i] >= count)
          throw InputError(name, where, "index " + std::to_string(idx[i]) + " out of range (" + std::to_string(count) + " positions)");
      }
    } else {
      idx.resize(count);
      for (size_t i = 0; i < count; ++i) idx[i] = static_cast<uint32_t>(i);
    }
    const bool flip = glm::determinant(glm::dmat3(xf)) < 0.0;  // mirrored nodes keep outward winding
    auto emit = [&](uint32_t a, uint32_t b, uint32_t c) {
      if (flip) std::swap(b, c);
      mesh.triangles.push_back({base + a, base + b, base + c});
    };
    if (mode == TINYGLTF_MODE_TRIANGLES) {
      for (size_t i = 0; i + 2 < idx.size(); i += 3) emit(idx[i], idx[i + 1], idx[i + 2]);
    } else if (mode == TINYGLTF_MODE_TRIANGLE_STRIP) {
      for (size_t i = 0; i + 2 < idx.size(); ++i)
        (i % 2 == 0) ? emit(idx[i], idx[i + 1], idx[i + 2]) : emit(idx[i + 1], idx[i], idx[i + 2]);
    } else {
      for (size_t i = 1; i + 1 < idx.size(); ++i) emit(idx[0], idx[i], idx[i + 1]);
    }
  }

  void add_mesh(int mesh_index, const glm::dmat4& xf) {
    if (mesh_index < 0 || mesh_index >= static_cast<int>(model.meshes.size()))
      throw InputError(name, "mesh " + std::to_string(mesh_index), "does not exist");
    const auto& m = model.meshes[static_cast<size_t>(mesh_index)];
    for (size_t p = 0; p < m.primitives.size(); ++p)
      add_primitive(m.primitives[p], xf, "mesh " + std::to_string(mesh_index) + " primitive " + std::to_string(p));
  }

  static glm::dmat4 local_transform(const tinygltf::Node& n) {
    if (n.matrix.size() == 16) return glm::make_mat4(n.matrix.data());
    glm::dmat4 t(1.0), r(1.0), s(1.0);
    if (n.translation.size() == 3) t[3] = glm::dvec4(n.translation[0], n.translation[1], n.translation[2], 1.0);
    if (n.rotation.size() == 4)
      r = glm::dmat4(glm::mat3_cast(glm::normalize(glm::dquat(n.rotation[3], n.rotation[0], n.rotation[1], n.rotation[2]))));
    if (n.scale.size() == 3) s = glm::dmat4(glm::dmat3(glm::dvec3(n.scale[0], 0, 0), glm::dvec3(0, n.scale[1], 0),
                                                       glm::dvec3(0, 0, n.scale[2])));
    return t * r * s;
  }

  void add_node(int node, const glm::dmat4& parent, int depth) {
    if (node < 0 || node >= static_cast<int>(model.nodes.size()))
      throw InputError(name, "node " + std::to_string(node), "does not exist");
    if (depth > 64) throw InputError(name, "node " + std::to_string(node), "node hierarchy deeper than 64 (a cycle?)");
    const auto& n = model.nodes[static_cast<size_t>(node)];
    const glm::dmat4 xf = parent * local_transform(n);
    if (n.mesh >= 0) add_mesh(n.mesh, xf);
    for (int c : n.children) add_node(c, xf, depth + 1);
  }
};

}  // namespace

TriangleMesh parse_gltf(std::string_view bytes, const std::string& name, const std::string& base_dir) {
  tinygltf::TinyGLTF loader;
  loader.SetImageLoader(&ignore_image, nullptr);
  tinygltf::Model model;
  std::string err, warn;
  if (bytes.size() > std::numeric_limits<unsigned int>::max()) throw InputError(name, "", "file too large");
  bool ok = false;
  try {
    if (bytes.size() >= 4 && bytes.substr(0, 4) == "glTF")
      ok = loader.LoadBinaryFromMemory(&model, &err, &warn, reinterpret_cast<const unsigned char*>(bytes.data()),
                                       static_cast<unsigned int>(bytes.size()), base_dir);
    else
      ok = loader.LoadASCIIFromString(&model, &err, &warn, bytes.data(), static_cast<unsigned int>(bytes.size()), base_dir);
  } catch (const std::exception& e) {
    throw InputError(name, "glTF", e.what());
  }
  if (!ok) {
    std::string msg = err.empty() ? "tinygltf could not parse it" : err;
    std::replace(msg.begin(), msg.end(), '\n', ' ');
    while (!msg.empty() && msg.back() == ' ') msg.pop_back();
    throw InputError(name, "glTF", msg);
  }
  // Compressed geometry required without a fallback: the accessors hold no readable positions.
  for (const std::string& ext : model.extensionsRequired)
    if (ext == "KHR_draco_mesh_compression" || ext == "EXT_meshopt_compression" || ext == "KHR_meshopt_compression")
      throw InputError(name, "glTF", "requires " + ext + " (compressed geometry), which this reader cannot decode");
  TriangleMesh mesh;
  GltfReader reader{model, name, mesh};
  if (model.scenes.empty() && model.nodes.empty()) {
    for (size_t m = 0; m < model.meshes.size(); ++m) reader.add_mesh(static_cast<int>(m), glm::dmat4(1.0));
  } else if (model.scenes.empty()) {
    std::vector<bool> is_child(model.nodes.size(), false);
    for (const auto& n : model.nodes)
      for (int c : n.children)
        if (c >= 0 && c < static_cast<int>(model.nodes.size())) is_child[static_cast<size_t>(c)] = true;
    for (size_t n = 0; n < model.nodes.size(); ++n)
      if (!is_child[n]) reader.add_node(static_cast<int>(n), glm::dmat4(1.0), 0);
  } else {
    const int s = model.defaultScene >= 0 ? model.defaultScene : 0;
    if (s >= static_cast<int>(model.scenes.size())) throw InputError(name, "scene " + std::to_string(s), "does not exist");
    for (int n : model.scenes[static_cast<size_t>(s)].nodes) reader.add_node(n, glm::dmat4(1.0), 0);
  }
  return mesh;
}

// ---- common -------------------------------------------------------------------

const char* mesh_format_name(MeshFormat format) {
  switch (format) {
    case MeshFormat::Ply: return "PLY";
    case MeshFormat::Gltf: return "glTF";
    case MeshFormat::Obj: break;
  }
  return "OBJ";
}

MeshFormat mesh_format_of(std::string_view v) {
  if (v.size() >= 4 && v.substr(0, 3) == "ply" && (v[3] == '\n' || v[3] == '\r')) return MeshFormat::Ply;
  if (v.size() >= 4 && v.substr(0, 4) == "glTF") return MeshFormat::Gltf;
  const size_t first = v.find_first_not_of(" \t\r\n");
  if (first != std::string_view::npos && v[first] == '{') return MeshFormat::Gltf;
  return MeshFormat::Obj;
}

TriangleMesh load_mesh(const std::string& path, MeshFormat* format) {
  const std::string bytes = scene::read_file(path);
  const std::string_view v(bytes);
  const MeshFormat f = mesh_format_of(v);
  if (format) *format = f;
  if (f == MeshFormat::Ply) return parse_ply(v, path);
  if (f == MeshFormat::Obj) return parse_obj(v, path);
  const size_t slash = path.find_last_of('/');
  return parse_gltf(v, path, slash == std::string::npos ? "" : path.substr(0, slash));
}

MeshBounds mesh_bounds(const TriangleMesh& mesh) {
  MeshBounds b;
  if (mesh.positions.empty()) return b;
  b.min = b.max = mesh.positions[0];
  for (const auto& p : mesh.positions) {
    b.min = glm::min(b.min, p);
    b.max = glm::max(b.max, p);
  }
  return b;
}

void gltf_y_up_to_z_up(TriangleMesh& mesh) {
  for (auto& p : mesh.positions) p = glm::dvec3(p.x, -p.z, p.y);
}

std::string mesh_to_obj(const TriangleMesh& mesh, const std::vector<std::string>& header) {
  std::string out;
  for (const auto& h : header) out += "# " + h + "\n";
  char buf[128];
  auto fmt = [](double x) { return std::abs(x) < 5e-7 ? 0.0 : x; };
  for (const auto& p : mesh.positions) {
    std::snprintf(buf, sizeof buf, "v %.6f %.6f %.6f\n", fmt(p.x), fmt(p.y), fmt(p.z));
    out += buf;
  }
  for (const auto& t : mesh.triangles) {
    std::snprintf(buf, sizeof buf, "f %u %u %u\n", t.x + 1, t.y + 1, t.z + 1);
    out += buf;
  }
  return out;
}

}  // namespace icube::world

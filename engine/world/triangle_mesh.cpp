// Mesh readers (PLY, OBJ, glTF/GLB) and the OBJ writer; see triangle_mesh.h.
// tinygltf's implementation lives in tinygltf_impl.cpp (same configuration macros).
#include "world/triangle_mesh.h"

#include "scene/atomic_file.h"
#include "scene/input_error.h"

#define TINYGLTF_NO_STB_IMAGE
#define TINYGLTF_NO_STB_IMAGE_WRITE
#define TINYGLTF_NO_EXTERNAL_IMAGE
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wshadow"
#pragma GCC diagnostic ignored "-Wdouble-promotion"
#pragma GCC diagnostic ignored "-Wunused-parameter"
#include <tiny_gltf.h>
#pragma GCC diagnostic pop

#include <glm/gtc/quaternion.hpp>
#include <glm/gtc/type_ptr.hpp>

#include <algorithm>
#include <bit>
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

// ---- PLY ----------------------------------------------------------------------

enum class PlyType : uint8_t { I8, U8, I16, U16, I32, U32, F32, F64 };

bool ply_type(std::string_view s, PlyType& t) {
  static const std::pair<const char*, PlyType> kTypes[] = {
      {"char", PlyType::I8},   {"int8", PlyType::I8},     {"uchar", PlyType::U8},   {"uint8", PlyType::U8},
      {"short", PlyType::I16}, {"int16", PlyType::I16},   {"ushort", PlyType::U16}, {"uint16", PlyType::U16},
      {"int", PlyType::I32},   {"int32", PlyType::I32},   {"uint", PlyType::U32},   {"uint32", PlyType::U32},
      {"float", PlyType::F32}, {"float32", PlyType::F32}, {"double", PlyType::F64}, {"float64", PlyType::F64}};
  for (const auto& [n, v] : kTypes)
    if (s == n) {
      t = v;
      return true;
    }
  return false;
}

size_t ply_size(PlyType t) {
  switch (t) {
    case PlyType::I8: case PlyType::U8: return 1;
    case PlyType::I16: case PlyType::U16: return 2;
    case PlyType::I32: case PlyType::U32: case PlyType::F32: return 4;
    case PlyType::F64: return 8;
  }
  return 1;
}

bool ply_is_int(PlyType t) { return t != PlyType::F32 && t != PlyType::F64; }

struct PlyProperty {
  std::string name;
  PlyType type = PlyType::F32;
  bool is_list = false;
  PlyType count_type = PlyType::U8;
};

struct PlyElement {
  std::string name;
  uint64_t count = 0;
  std::vector<PlyProperty> props;
};

enum class PlyFormat { Ascii, BinaryLE, BinaryBE };

// Reads the body's values one at a time, ascii or binary, with bounds checks.
class PlyBody {
 public:
  PlyBody(std::string_view body, PlyFormat format, size_t first_line)
      : body_(body), format_(format), line_(first_line) {}

  // Reads one value of type t; `where` names the element instance for errors.
  double read(PlyType t, const std::string& name, const std::string& where) {
    if (format_ == PlyFormat::Ascii) return read_ascii(t, name, where);
    const size_t n = ply_size(t);
    if (pos_ + n > body_.size()) throw InputError(name, where, "file ends early");
    unsigned char b[8];
    std::memcpy(b, body_.data() + pos_, n);
    pos_ += n;
    if ((format_ == PlyFormat::BinaryBE) == (std::endian::native == std::endian::little)) std::reverse(b, b + n);
    switch (t) {
      case PlyType::I8: { int8_t v; std::memcpy(&v, b, 1); return v; }
      case PlyType::U8: return b[0];
      case PlyType::I16: { int16_t v; std::memcpy(&v, b, 2); return v; }
      case PlyType::U16: { uint16_t v; std::memcpy(&v, b, 2); return v; }
      case PlyType::I32: { int32_t v; std::memcpy(&v, b, 4); return v; }
      case PlyType::U32: { uint32_t v; std::memcpy(&v, b, 4); return v; }
      case PlyType::F32: { float v; std::memcpy(&v, b, 4); return static_cast<double>(v); }
      case PlyType::F64: { double v; std::memcpy(&v, b, 8); return v; }
    }
    return 0.0;
  }
  // " (line N)" for ascii bodies, "" for binary ones.
  std::string line_note() const { return format_ == PlyFormat::Ascii ? " (line " + std::to_string(line_) + ")" : ""; }

 private:
  double read_ascii(PlyType t, const std::string& name, const std::string& where) {
    while (pos_ < body_.size() && is_space(body_[pos_])) {
      if (body_[pos_] == '\n') ++line_;
      ++pos_;
    }
    size_t end = pos_;
    while (end < body_.size() && !is_space(body_[end])) ++end;
    if (end == pos_) throw InputError(name, where + line_note(), "file ends early");
    const std::string_view tok = body_.substr(pos_, end - pos_);
    pos_ = end;
    if (ply_is_int(t)) {
      int64_t v = 0;
      if (!parse_int(tok, v)) throw InputError(name, where + line_note(), "bad integer " + quoted(tok));
      return static_cast<double>(v);
    }
    double v = 0.0;
    if (!parse_double(tok, v)) throw InputError(name, where + line_note(), "bad number " + quoted(tok));
    return v;
  }

  std::string_view body_;
  PlyFormat format_;
  size_t pos_ = 0;
  size_t line_;
};

}  // namespace

TriangleMesh parse_ply(std::string_view bytes, const std::string& name) {
  // ---- header
  std::vector<PlyElement> elements;
  PlyFormat format = PlyFormat::Ascii;
  bool have_format = false;
  size_t pos = 0, line_no = 0;
  bool ended = false;
  while (pos < bytes.size() && !ended) {
    size_t nl = bytes.find('\n', pos);
    if (nl == std::string_view::npos) break;
    const std::string_view line = bytes.substr(pos, nl - pos);
    pos = nl + 1;
    ++line_no;
    const std::string where = "header line " + std::to_string(line_no);
    const auto tok = tokens_of(line);
    if (line_no == 1) {
      if (tok.size() != 1 || tok[0] != "ply") throw InputError(name, where, "not a PLY file (no 'ply' magic)");
      continue;
    }
    if (tok.empty() || tok[0] == "comment" || tok[0] == "obj_info") continue;
    if (tok[0] == "format") {
      if (tok.size() != 3) throw InputError(name, where, "bad format line");
      if (tok[1] == "ascii") format = PlyFormat::Ascii;
      else if (tok[1] == "binary_little_endian") format = PlyFormat::BinaryLE;
      else if (tok[1] == "binary_big_endian") format = PlyFormat::BinaryBE;
      else throw InputError(name, where, "unknown format " + quoted(tok[1]));
      have_format = true;
    } else if (tok[0] == "element") {
      int64_t count = 0;
      if (tok.size() != 3 || !parse_int(tok[2], count) || count < 0)
        throw InputError(name, where, "bad element line");
      elements.push_back({std::string(tok[1]), static_cast<uint64_t>(count), {}});
    } else if (tok[0] == "property") {
      if (elements.empty()) throw InputError(name, where, "property before any element");
      PlyProperty p;
      if (tok.size() == 5 && tok[1] == "list") {
        p.is_list = true;
        if (!ply_type(tok[2], p.count_type) || !ply_type(tok[3], p.type) || !ply_is_int(p.count_type))
          throw InputError(name, where, "bad list property types");
        p.name = tok[4];
      } else if (tok.size() == 3) {
        if (!ply_type(tok[1], p.type)) throw InputError(name, where, "unknown property type " + quoted(tok[1]));
        p.name = tok[2];
      } else {
        throw InputError(name, where, "bad property line");
      }
      elements.back().props.push_back(p);
    } else if (tok[0] == "end_header") {
      ended = true;
    } else {
      throw InputError(name, where, "unknown header keyword " + quoted(tok[0]));
    }
  }
  if (!ended) throw InputError(name, "header", "no end_header");
  if (!have_format) throw InputError(name, "header", "no format line");

  // The smallest possible size of each element instance bounds the counts before anything is allocated.
  for (const auto& e : elements) {
    uint64_t min_size = 0;
    for (const auto& p : e.props) min_size += format == PlyFormat::Ascii ? 2 : ply_size(p.is_list ? p.count_type : p.type);
    if (min_size > 0 && e.count > (bytes.size() - pos) / min_size + 1)
      throw InputError(name, "element " + e.name, std::to_string(e.count) + " entries cannot fit in the file");
  }

  // ---- body
  TriangleMesh mesh;
  PlyBody body(bytes.substr(pos), format, line_no + 1);
  bool have_vertex = false, have_face = false;
  for (const auto& e : elements) {
    const bool is_vertex = e.name == "vertex", is_face = e.name == "face";
    int xyz[3] = {-1, -1, -1}, idx = -1;
    for (size_t k = 0; k < e.props.size(); ++k) {
      const auto& p = e.props[k];
      if (is_vertex && !p.is_list && p.name.size() == 1 && p.name[0] >= 'x' && p.name[0] <= 'z')
        xyz[p.name[0] - 'x'] = static_cast<int>(k);
      if (is_face && p.is_list && (p.name == "vertex_indices" || p.name == "vertex_index")) idx = static_cast<int>(k);
    }
    if (is_vertex) {
      if (xyz[0] < 0 || xyz[1] < 0 || xyz[2] < 0) throw InputError(name, "element vertex", "no x, y, z properties");
      have_vertex = true;
      mesh.positions.reserve(e.count);
    }
    if (is_face) {
      if (idx < 0) throw InputError(name, "element face", "no vertex_indices list");
      have_face = true;
      mesh.triangles.reserve(e.count);
    }
    if (e.props.empty()) continue;  // nothing to read, however large the count
    std::vector<uint32_t> poly;
    for (uint64_t i = 0; i < e.count; ++i) {
      const std::string where = e.name + " " + std::to_string(i);
      glm::dvec3 v(0.0);
      for (size_t k = 0; k < e.props.size(); ++k) {
        const auto& p = e.props[k];
        if (!p.is_list) {
          const double value = body.read(p.type, name, where);
          for (int a = 0; a < 3; ++a)
            if (is_vertex && xyz[a] == static_cast<int>(k)) v[a] = value;
          continue;
        }
        const double n = body.read(p.count_type, name, where);
        if (n < 0) throw InputError(name, where + body.line_note(), "negative list length");
        const bool wanted = is_face && static_cast<int>(k) == idx;
        if (wanted && n < 3)
          throw InputError(name, where + body.line_note(), "face with " + std::to_string(static_cast<int>(n)) + " vertices");
        poly.clear();
        for (uint64_t j = 0; j < static_cast<uint64_t>(n); ++j) {
          const double id = body.read(p.type, name, where);
          if (!wanted) continue;
          if (!ply_is_int(p.type) || id < 0 || id > static_cast<double>(std::numeric_limits<uint32_t>::max()))
            throw InputError(name, where + body.line_note(), "bad vertex index " + std::to_string(id));
          if (have_vertex && id >= static_cast<double>(mesh.positions.size()))
            throw InputError(name, where + body.line_note(),
                             "vertex index " + std::to_string(static_cast<uint64_t>(id)) + " out of range (" +
                                 std::to_string(mesh.positions.size()) + " vertices)");
          poly.push_back(static_cast<uint32_t>(id));
        }
        for (size_t j = 1; j + 1 < poly.size(); ++j) mesh.triangles.push_back({poly[0], poly[j], poly[j + 1]});
      }
      if (is_vertex) {
        if (!std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z))
          throw InputError(name, where + body.line_note(), "coordinate is not finite");
        mesh.positions.push_back(v);
      }
    }
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

  void add_primitive(const tinygltf::Primitive& prim, const glm::dmat4& xf, const std::string& where) {
    const int mode = prim.mode < 0 ? TINYGLTF_MODE_TRIANGLES : prim.mode;
    if (mode != TINYGLTF_MODE_TRIANGLES && mode != TINYGLTF_MODE_TRIANGLE_STRIP && mode != TINYGLTF_MODE_TRIANGLE_FAN)
      return;  // points and lines have no surface
    const auto it = prim.attributes.find("POSITION");
    if (it == prim.attributes.end()) throw InputError(name, where, "no POSITION attribute");
    size_t stride = 0, count = 0;
    const unsigned char* p =
        accessor_data(it->second, TINYGLTF_TYPE_VEC3, {TINYGLTF_COMPONENT_TYPE_FLOAT}, stride, count, where);
    const uint32_t base = static_cast<uint32_t>(mesh.positions.size());
    for (size_t i = 0; i < count; ++i) {
      float f[3];
      std::memcpy(f, p + i * stride, sizeof f);
      const glm::dvec4 w = xf * glm::dvec4(f[0], f[1], f[2], 1.0);
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
  TriangleMesh mesh;
  GltfReader reader{model, name, mesh};
  if (model.scenes.empty()) {
    for (size_t m = 0; m < model.meshes.size(); ++m) reader.add_mesh(static_cast<int>(m), glm::dmat4(1.0));
  } else {
    const int s = model.defaultScene >= 0 ? model.defaultScene : 0;
    if (s >= static_cast<int>(model.scenes.size())) throw InputError(name, "scene " + std::to_string(s), "does not exist");
    for (int n : model.scenes[static_cast<size_t>(s)].nodes) reader.add_node(n, glm::dmat4(1.0), 0);
  }
  return mesh;
}

// ---- common -------------------------------------------------------------------

TriangleMesh load_mesh(const std::string& path) {
  const std::string bytes = scene::read_file(path);
  const std::string_view v(bytes);
  if (v.size() >= 4 && v.substr(0, 3) == "ply" && (v[3] == '\n' || v[3] == '\r')) return parse_ply(v, path);
  const size_t slash = path.find_last_of('/');
  const std::string dir = slash == std::string::npos ? "" : path.substr(0, slash);
  if (v.size() >= 4 && v.substr(0, 4) == "glTF") return parse_gltf(v, path, dir);
  const size_t first = v.find_first_not_of(" \t\r\n");
  if (first != std::string_view::npos && v[first] == '{') return parse_gltf(v, path, dir);
  return parse_obj(v, path);
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

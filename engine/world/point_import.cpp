// Point readers (.npy, .ply) and the sort-based majority-vote voxelizer.
#include "world/point_import.h"

#include "scene/atomic_file.h"
#include "scene/input_error.h"
#include "world/npy.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <optional>
#include <sstream>

namespace icube::world {

namespace {

std::string row_where(uint64_t row) { return "row " + std::to_string(row); }

// Validates one row's values and appends it (class 0 rows are counted by the caller and skipped).
void add_point(std::vector<LabeledPoint>& out, const std::string& name, uint64_t row, double x, double y, double z,
               double cls, double inst) {
  if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z))
    throw scene::InputError(name, row_where(row), "coordinate is NaN or infinite");
  if (!std::isfinite(cls) || cls != std::floor(cls) || cls < 0.0 || cls >= kNumSemanticClasses) {
    std::ostringstream s;
    s << "class " << cls << " is not an integer in 0..22";
    throw scene::InputError(name, row_where(row), s.str());
  }
  if (!std::isfinite(inst) || inst != std::floor(inst) || inst < 0.0 || inst > 65535.0) {
    std::ostringstream s;
    s << "instance " << inst << " is not an integer in 0..65535";
    throw scene::InputError(name, row_where(row), s.str());
  }
  if (cls == 0.0) return;
  out.push_back({{x, y, z}, static_cast<uint8_t>(cls), static_cast<uint16_t>(inst)});
}

// ---- PLY -------------------------------------------------------------------

enum class PlyType { I8, U8, I16, U16, I32, U32, F32, F64 };

std::optional<PlyType> ply_type(const std::string& t) {
  if (t == "char" || t == "int8") return PlyType::I8;
  if (t == "uchar" || t == "uint8") return PlyType::U8;
  if (t == "short" || t == "int16") return PlyType::I16;
  if (t == "ushort" || t == "uint16") return PlyType::U16;
  if (t == "int" || t == "int32") return PlyType::I32;
  if (t == "uint" || t == "uint32") return PlyType::U32;
  if (t == "float" || t == "float32") return PlyType::F32;
  if (t == "double" || t == "float64") return PlyType::F64;
  return std::nullopt;
}

size_t ply_size(PlyType t) {
  switch (t) {
    case PlyType::I8:
    case PlyType::U8: return 1;
    case PlyType::I16:
    case PlyType::U16: return 2;
    case PlyType::I32:
    case PlyType::U32:
    case PlyType::F32: return 4;
    case PlyType::F64: return 8;
  }
  return 0;
}

double ply_decode(PlyType t, const char* p) {
  switch (t) {
    case PlyType::I8: return static_cast<int8_t>(p[0]);
    case PlyType::U8: return static_cast<uint8_t>(p[0]);
    case PlyType::I16: { int16_t v; std::memcpy(&v, p, 2); return v; }
    case PlyType::U16: { uint16_t v; std::memcpy(&v, p, 2); return v; }
    case PlyType::I32: { int32_t v; std::memcpy(&v, p, 4); return v; }
    case PlyType::U32: { uint32_t v; std::memcpy(&v, p, 4); return v; }
    case PlyType::F32: { float v; std::memcpy(&v, p, 4); return static_cast<double>(v); }
    case PlyType::F64: { double v; std::memcpy(&v, p, 8); return v; }
  }
  return 0.0;
}

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

// Reads values one at a time from the body, ascii tokens or binary little-endian.
class PlyBody {
 public:
  PlyBody(std::string_view body, bool ascii, size_t base, const std::string& name)
      : s_(body), ascii_(ascii), base_(base), name_(name) {}
  double next(PlyType t, uint64_t row) {
    if (ascii_) {
      while (pos_ < s_.size() && std::isspace(static_cast<unsigned char>(s_[pos_]))) ++pos_;
      const size_t start = pos_;
      while (pos_ < s_.size() && !std::isspace(static_cast<unsigned char>(s_[pos_]))) ++pos_;
      if (start == pos_) throw scene::InputError(name_, row_where(row), "file ends inside the vertex data");
      const std::string tok(s_.substr(start, pos_ - start));
      char* end = nullptr;
      const double v = std::strtod(tok.c_str(), &end);
      if (end != tok.c_str() + tok.size())
        throw scene::InputError(name_, row_where(row), "'" + tok + "' is not a number");
      return v;
    }
    const size_t n = ply_size(t);
    if (n > s_.size() - pos_)
      throw scene::InputError(name_, row_where(row) + " at byte " + std::to_string(base_ + pos_),
                              "file ends inside the vertex data");
    const double v = ply_decode(t, s_.data() + pos_);
    pos_ += n;
    return v;
  }

 private:
  std::string_view s_;
  bool ascii_;
  size_t base_;
  const std::string& name_;
  size_t pos_ = 0;
};

}  // namespace

std::vector<LabeledPoint> points_from_ply_bytes(std::string_view bytes, const std::string& name, uint64_t* rows) {
  const size_t end = bytes.find("end_header");
  if (bytes.substr(0, 3) != "ply" || end == std::string_view::npos)
    throw scene::InputError(name, "header", "not a PLY file (no 'ply' magic or no 'end_header')");
  size_t body_start = bytes.find('\n', end);
  if (body_start == std::string_view::npos) throw scene::InputError(name, "header", "no newline after end_header");
  ++body_start;
  std::istringstream header{std::string(bytes.substr(0, end))};
  std::string line, format;
  std::vector<PlyElement> elements;
  int line_no = 0;
  while (std::getline(header, line)) {
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    std::istringstream ls(line);
    std::string kw;
    ls >> kw;
    const std::string where = "header line " + std::to_string(line_no);
    if (kw.empty() || kw == "ply" || kw == "comment" || kw == "obj_info") continue;
    if (kw == "format") {
      ls >> format;
      if (format != "ascii" && format != "binary_little_endian")
        throw scene::InputError(name, where, "format '" + format + "' is not supported (ascii or binary_little_endian)");
    } else if (kw == "element") {
      PlyElement e;
      if (!(ls >> e.name >> e.count)) throw scene::InputError(name, where, "malformed element line");
      elements.push_back(std::move(e));
    } else if (kw == "property") {
      if (elements.empty()) throw scene::InputError(name, where, "property before any element");
      PlyProperty p;
      std::string t;
      ls >> t;
      if (t == "list") {
        std::string ct, it;
        ls >> ct >> it >> p.name;
        auto c = ply_type(ct), v = ply_type(it);
        if (!c || !v || p.name.empty()) throw scene::InputError(name, where, "malformed list property");
        p.is_list = true;
        p.count_type = *c;
        p.type = *v;
      } else {
        auto v = ply_type(t);
        ls >> p.name;
        if (!v || p.name.empty()) throw scene::InputError(name, where, "unknown property type '" + t + "'");
        p.type = *v;
      }
      elements.back().props.push_back(p);
    } else {
      throw scene::InputError(name, where, "unexpected header keyword '" + kw + "'");
    }
  }
  if (format.empty()) throw scene::InputError(name, "header", "no format line");
  const auto vit = std::find_if(elements.begin(), elements.end(), [](const PlyElement& e) { return e.name == "vertex"; });
  if (vit == elements.end()) throw scene::InputError(name, "header", "no 'vertex' element");
  int ix = -1, iy = -1, iz = -1, ic = -1, ii = -1;
  for (size_t k = 0; k < vit->props.size(); ++k) {
    const PlyProperty& p = vit->props[k];
    const int kk = static_cast<int>(k);
    if (p.is_list) continue;
    if (p.name == "x") ix = kk;
    if (p.name == "y") iy = kk;
    if (p.name == "z") iz = kk;
    if (p.name == "class" || p.name == "label" || p.name == "semantic") ic = kk;
    if (p.name == "instance") ii = kk;
  }
  if (ix < 0 || iy < 0 || iz < 0) throw scene::InputError(name, "header", "vertex element lacks x, y or z");
  if (ic < 0) throw scene::InputError(name, "header", "vertex element has no 'class', 'label' or 'semantic' property");

  const std::string_view body = bytes.substr(body_start);
  const bool ascii = format == "ascii";
  if (!ascii) {  // bound the vertex count by the file size before allocating
    size_t rec = 0;
    for (const PlyProperty& p : vit->props) rec += p.is_list ? ply_size(p.count_type) : ply_size(p.type);
    if (vit->count > body.size() / std::max<size_t>(rec, 1))
      throw scene::InputError(name, "header", "vertex count " + std::to_string(vit->count) + " exceeds the file");
  } else if (vit->count > body.size() / 2 + 1) {
    throw scene::InputError(name, "header", "vertex count " + std::to_string(vit->count) + " exceeds the file");
  }
  PlyBody in(body, ascii, body_start, name);
  std::vector<LabeledPoint> out;
  for (auto e = elements.begin(); e != elements.end(); ++e) {
    const bool is_vertex = e == vit;
    if (is_vertex) {
      out.reserve(static_cast<size_t>(e->count));
      if (rows) *rows = e->count;
    }
    std::vector<double> vals(e->props.size(), 0.0);
    for (uint64_t row = 0; row < e->count; ++row) {
      for (size_t k = 0; k < e->props.size(); ++k) {
        const PlyProperty& p = e->props[k];
        if (p.is_list) {
          const double n = in.next(p.count_type, row);
          if (!(n >= 0.0) || n > 1e9) throw scene::InputError(name, row_where(row), "bad list length");
          for (uint64_t j = 0; j < static_cast<uint64_t>(n); ++j) in.next(p.type, row);
        } else {
          vals[k] = in.next(p.type, row);
        }
      }
      if (is_vertex)
        add_point(out, name, row, vals[static_cast<size_t>(ix)], vals[static_cast<size_t>(iy)],
                  vals[static_cast<size_t>(iz)], vals[static_cast<size_t>(ic)],
                  ii >= 0 ? vals[static_cast<size_t>(ii)] : 0.0);
    }
    if (is_vertex) break;
  }
  return out;
}

std::vector<LabeledPoint> read_points_ply(const std::string& path) {
  return points_from_ply_bytes(scene::read_file(path), path);
}

namespace {

std::vector<LabeledPoint> points_from_npy(const NpyArray& a, const std::string& path) {
  if (a.dtype != NpyDtype::F4 && a.dtype != NpyDtype::F8)
    throw scene::InputError(path, "npy header",
                            std::string("points must be <f4 or <f8, not ") + npy_dtype_descr(a.dtype));
  if (a.shape.size() != 2 || (a.shape[1] != 4 && a.shape[1] != 5))
    throw scene::InputError(path, "npy header", "points must have shape (N, 4) or (N, 5): x, y, z, class[, instance]");
  const size_t cols = static_cast<size_t>(a.shape[1]);
  std::vector<LabeledPoint> out;
  out.reserve(static_cast<size_t>(a.shape[0]));
  for (uint64_t r = 0; r < a.shape[0]; ++r) {
    const size_t b = static_cast<size_t>(r) * cols;
    add_point(out, path, r, a.as_double(b), a.as_double(b + 1), a.as_double(b + 2), a.as_double(b + 3),
              cols == 5 ? a.as_double(b + 4) : 0.0);
  }
  return out;
}

}  // namespace

std::vector<LabeledPoint> read_points_npy(const std::string& path) { return points_from_npy(read_npy(path), path); }

VoxelGrid voxelize_points(const std::vector<LabeledPoint>& points, const glm::dvec3& origin, double voxel_size,
                          const std::string& name) {
  VoxelGrid grid(origin, voxel_size);
  struct Rec {
    glm::ivec3 ijk;
    uint8_t cls;
    uint16_t inst;
  };
  std::vector<Rec> recs;
  recs.reserve(points.size());
  for (size_t r = 0; r < points.size(); ++r) {
    const glm::ivec3 ijk = grid.world_to_ijk(points[r].position);
    if (!ijk_in_range(ijk))
      throw scene::InputError(name, "point " + std::to_string(r),
                              "lies outside the +-2^23 voxel range around the origin; pass --origin nearer the data");
    recs.push_back({ijk, points[r].class_id, points[r].instance});
  }
  std::sort(recs.begin(), recs.end(), [](const Rec& a, const Rec& b) {
    if (a.ijk.z != b.ijk.z) return a.ijk.z < b.ijk.z;
    if (a.ijk.y != b.ijk.y) return a.ijk.y < b.ijk.y;
    if (a.ijk.x != b.ijk.x) return a.ijk.x < b.ijk.x;
    if (a.cls != b.cls) return a.cls < b.cls;
    return a.inst < b.inst;
  });
  for (size_t i = 0; i < recs.size();) {
    size_t j = i;
    uint8_t best_cls = 0;
    uint16_t best_inst = 0;
    size_t best_count = 0;
    while (j < recs.size() && recs[j].ijk == recs[i].ijk) {  // one class run at a time, ascending
      size_t k = j, inst_best_n = 0;
      uint16_t inst_best = 0;
      while (k < recs.size() && recs[k].ijk == recs[i].ijk && recs[k].cls == recs[j].cls) {
        size_t m = k;
        while (m < recs.size() && recs[m].ijk == recs[i].ijk && recs[m].cls == recs[j].cls &&
               recs[m].inst == recs[k].inst)
          ++m;
        if (m - k > inst_best_n) {  // strict: ties keep the lower instance
          inst_best_n = m - k;
          inst_best = recs[k].inst;
        }
        k = m;
      }
      if (k - j > best_count) {  // strict: ties keep the lower class
        best_count = k - j;
        best_cls = recs[j].cls;
        best_inst = inst_best;
      }
      j = k;
    }
    grid.set(recs[i].ijk, best_cls, best_inst);
    i = j;
  }
  return grid;
}

VoxelGrid import_points(const std::string& path, const glm::dvec3& origin, double voxel_size, ImportStats* stats) {
  const std::string bytes = scene::read_file(path);
  std::vector<LabeledPoint> pts;
  uint64_t rows = 0;
  if (bytes.compare(0, 6, "\x93NUMPY") == 0) {
    const NpyArray a = npy_from_bytes(bytes, path);
    rows = a.shape.empty() ? 1 : a.shape[0];
    pts = points_from_npy(a, path);
  } else if (bytes.compare(0, 3, "ply") == 0) {
    pts = points_from_ply_bytes(bytes, path, &rows);
  } else {
    throw scene::InputError(path, "byte 0", "not a .npy or .ply point file");
  }
  VoxelGrid g = voxelize_points(pts, origin, voxel_size, path);
  if (stats) {
    stats->points = rows;
    stats->labelled_points = pts.size();
    stats->voxels = g.voxel_count();
  }
  return g;
}

}  // namespace icube::world

// Point readers (.npy, .ply) and the sort-based majority-vote voxelizer.
#include "world/point_import.h"

#include "scene/atomic_file.h"
#include "scene/input_error.h"
#include "world/npy.h"
#include "world/ply_reader.h"

#include <algorithm>
#include <cmath>
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

// ---- PLY (header and values from world/ply_reader.h) ----------------------

// Reads one value of the row, with the point reader's own messages.
double next_value(PlyCursor& in, PlyType t, const std::string& name, uint64_t row) {
  const size_t at = in.byte();
  double v = 0.0;
  switch (in.next(t, v)) {
    case PlyCursor::Status::Ok: return v;
    case PlyCursor::Status::End:
      throw scene::InputError(name, in.ascii() ? row_where(row) : row_where(row) + " at byte " + std::to_string(at),
                              "file ends inside the vertex data");
    case PlyCursor::Status::BadInteger:
    case PlyCursor::Status::BadNumber: break;
  }
  throw scene::InputError(name, row_where(row), "'" + std::string(in.token()) + "' is not a number");
}

// Reads one row; scalar values land in vals (list items are skipped).
void read_row(PlyCursor& in, const PlyElement& e, std::vector<double>& vals, const std::string& name, uint64_t row) {
  for (size_t k = 0; k < e.props.size(); ++k) {
    const PlyProperty& p = e.props[k];
    if (!p.is_list) {
      vals[k] = next_value(in, p.type, name, row);
      continue;
    }
    const double n = next_value(in, p.count_type, name, row);
    if (!(n >= 0.0) || n > 1e9) throw scene::InputError(name, row_where(row), "bad list length");
    for (uint64_t j = 0; j < static_cast<uint64_t>(n); ++j) next_value(in, p.type, name, row);
  }
}

// Column indices of the vertex element's x, y, z, class and instance (-1: absent).
struct PointColumns {
  int x = -1, y = -1, z = -1, cls = -1, inst = -1;
};

PointColumns point_columns(const PlyElement& v, const std::string& name) {
  PointColumns c;
  for (size_t k = 0; k < v.props.size(); ++k) {
    const PlyProperty& p = v.props[k];
    const int kk = static_cast<int>(k);
    if (p.is_list) continue;
    if (p.name == "x") c.x = kk;
    if (p.name == "y") c.y = kk;
    if (p.name == "z") c.z = kk;
    if (p.name == "class" || p.name == "label" || p.name == "semantic") c.cls = kk;
    if (p.name == "instance") c.inst = kk;
  }
  if (c.x < 0 || c.y < 0 || c.z < 0) throw scene::InputError(name, "header", "vertex element lacks x, y or z");
  if (c.cls < 0) throw scene::InputError(name, "header", "vertex element has no 'class', 'label' or 'semantic' property");
  return c;
}

PlyHeader point_header(std::string_view bytes, const std::string& name) {
  PlyHeader h = parse_ply_header(bytes, name);
  if (h.format == PlyFormat::BinaryBE)
    throw scene::InputError(name, "header line " + std::to_string(h.format_line),
                            "format 'binary_big_endian' is not supported (ascii or binary_little_endian)");
  return h;
}

}  // namespace

std::vector<LabeledPoint> points_from_ply_bytes(std::string_view bytes, const std::string& name, uint64_t* rows) {
  const PlyHeader h = point_header(bytes, name);
  const PlyElement* vertex = h.find("vertex");
  if (!vertex) throw scene::InputError(name, "header", "no 'vertex' element");
  const PointColumns c = point_columns(*vertex, name);
  const std::string_view body = bytes.substr(h.body_offset);
  if (!ply_rows_fit(*vertex, h.format, body.size()))  // bound the vertex count before allocating
    throw scene::InputError(name, "header", "vertex count " + std::to_string(vertex->count) + " exceeds the file");
  PlyCursor in(body, h.format, h.body_offset, h.header_lines + 1, PlyCursor::AsciiInts::Lenient);
  std::vector<LabeledPoint> out;
  out.reserve(static_cast<size_t>(vertex->count));
  if (rows) *rows = vertex->count;
  auto at = [](const std::vector<double>& v, int k) { return v[static_cast<size_t>(k)]; };
  for (const PlyElement& e : h.elements) {
    std::vector<double> vals(e.props.size(), 0.0);
    for (uint64_t row = 0; row < e.count; ++row) {
      read_row(in, e, vals, name, row);
      if (&e == vertex)
        add_point(out, name, row, at(vals, c.x), at(vals, c.y), at(vals, c.z), at(vals, c.cls),
                  c.inst >= 0 ? at(vals, c.inst) : 0.0);
    }
    if (&e == vertex) break;
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

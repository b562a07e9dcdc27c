// insert_object(): one mesh in a box into a world; see object_insert.h.
#include "world/object_insert.h"

#include "scene/input_error.h"
#include "world/mesh_voxelize.h"
#include "world/voxel_grid.h"

#include <algorithm>
#include <charconv>
#include <initializer_list>
#include <numbers>
#include <cmath>
#include <stdexcept>
#include <string>

namespace icube::world {
namespace {

void check_box(const scene::BoxState& b) {
  const double values[] = {b.center.x, b.center.y, b.center.z, b.length, b.width, b.height, b.heading, b.pitch, b.roll};
  for (double v : values)
    if (!std::isfinite(v)) throw std::invalid_argument("insert_object: box has a non-finite value");
  if (!(b.length > 0.0 && b.width > 0.0 && b.height > 0.0))
    throw std::invalid_argument("insert_object: box length, width and height must be positive");
}

// Appended piece by piece, as below: GCC 12 misreads chained std::string + here as an overlapping memcpy.
std::string quoted(std::string_view text, size_t max) {
  std::string out(1, '\'');
  out += scene::printable(text, max);
  out += '\'';
  return out;
}

}  // namespace

scene::BoxState parse_box_spec(std::string_view text) {
  static const char* const kField[7] = {"cx", "cy", "cz", "length", "width", "height", "heading"};
  auto fail = [&](std::initializer_list<std::string_view> parts) {
    std::string msg = quoted(text, 80) + ": ";
    for (std::string_view p : parts) msg.append(p);
    throw std::invalid_argument(msg);
  };
  double v[7] = {};
  size_t n = 0, start = 0;
  for (;;) {
    const size_t comma = std::min(text.find(',', start), text.size());
    const std::string_view raw = text.substr(start, comma - start);
    if (n == 7) fail({"expected 7 values cx,cy,cz,l,w,h,heading, got more"});
    std::string_view field = raw;
    double scale = 1.0;
    if (n == 6 && field.size() > 3 && field.substr(field.size() - 3) == "deg") {
      field.remove_suffix(3);
      scale = std::numbers::pi / 180.0;
    }
    if (!field.empty() && field[0] == '+') field.remove_prefix(1);
    const auto [p, ec] = std::from_chars(field.data(), field.data() + field.size(), v[n]);
    if (field.empty() || ec != std::errc() || p != field.data() + field.size())
      fail({kField[n], " ", quoted(raw, 40), " is not a number"});
    if (!std::isfinite(v[n])) fail({kField[n], " is not finite"});
    if (n >= 3 && n <= 5 && !(v[n] > 0.0)) fail({kField[n], " must be positive"});
    v[n++] *= scale;
    if (comma == text.size()) break;
    start = comma + 1;
  }
  if (n != 7) fail({"expected 7 values cx,cy,cz,l,w,h,heading, got ", std::to_string(n)});
  scene::BoxState b;
  b.center = glm::dvec3(v[0], v[1], v[2]);
  b.length = v[3], b.width = v[4], b.height = v[5], b.heading = v[6];
  b.valid = true;
  return b;
}

uint32_t next_instance_id(const VoxelGrid& grid) {
  uint32_t top = 0;
  for (const Brick& b : grid.bricks())
    for (int n = 0; n < kBrickVoxels; ++n)
      if ((b.mask[static_cast<size_t>(n / 64)] >> (n % 64)) & 1u)
        top = std::max<uint32_t>(top, b.instances[static_cast<size_t>(n)]);
  if (top >= 0xFFFFu) throw std::invalid_argument("next_instance_id: instance 65535 is taken; give an id explicitly");
  return top + 1;
}

ObjectInsertResult insert_object(VoxelGrid& grid, const TriangleMesh& mesh, const scene::BoxState& box,
                                 const ObjectInsertOptions& o) {
  check_box(box);
  if (o.class_id == 0 || o.class_id >= kNumSemanticClasses)
    throw std::invalid_argument("insert_object: class id " + std::to_string(o.class_id) + " is not a class");
  if (o.instance_id > 0xFFFFu)
    throw std::invalid_argument("insert_object: instance id " + std::to_string(o.instance_id) + " does not fit uint16");
  ObjectInsertResult r;
  r.instance_id = o.instance_id ? o.instance_id : next_instance_id(grid);
  VoteOptions vo;
  vo.cell = grid.voxel_size();
  vo.grid_origin = grid.origin();
  vo.min_sub_voxels = o.min_sub_voxels;
  vo.class_id = o.class_id;
  const auto cells = voxelize_vehicle(mesh, box, r.instance_id, vo);
  r.cells = cells.size();
  for (const auto& v : cells) {
    if (!ijk_in_range(v.ijk)) {
      ++r.out_of_range;
      continue;
    }
    if (grid.contains(v.ijk)) {
      if (!o.overwrite) {
        ++r.kept_existing;
        continue;
      }
      ++r.replaced;
    }
    grid.set(v.ijk, v.class_id, static_cast<uint16_t>(r.instance_id));
    ++r.written;
  }
  return r;
}

}  // namespace icube::world

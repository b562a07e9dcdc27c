// .icw writer and validating reader (format in world_file.h).
#include "world/world_file.h"

#include "scene/atomic_file.h"
#include "scene/input_error.h"

#include <array>
#include <bit>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <type_traits>

namespace icube::world {

namespace {

constexpr char kMagic[4] = {'I', 'C', 'W', '1'};
constexpr size_t kBrickFixedBytes = 12 + 64;  // coord + mask

std::array<uint32_t, 256> make_crc_table() {
  std::array<uint32_t, 256> t{};
  for (uint32_t n = 0; n < 256; ++n) {
    uint32_t c = n;
    for (int k = 0; k < 8; ++k) c = (c & 1) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
    t[n] = c;
  }
  return t;
}

template <class T>
void put(std::string& out, T v) {
  static_assert(std::is_trivially_copyable_v<T>);
  static_assert(std::endian::native == std::endian::little, "the .icw writer assumes a little-endian host");
  char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  out.append(b, sizeof(T));
}

class Reader {
 public:
  Reader(std::string_view bytes, const std::string& name) : bytes_(bytes), name_(name) {}
  template <class T>
  T get(const char* what) {
    need(sizeof(T), what);
    T v;
    std::memcpy(&v, bytes_.data() + pos_, sizeof(T));
    pos_ += sizeof(T);
    return v;
  }
  void need(size_t n, const char* what) const {
    if (n > end_ - pos_) fail(std::string("truncated: ") + what + " needs " + std::to_string(n) + " bytes");
  }
  [[noreturn]] void fail(const std::string& what) const { fail_at(pos_, what); }
  [[noreturn]] void fail_at(size_t at, const std::string& what) const {
    throw scene::InputError(name_, "byte " + std::to_string(at), what);
  }
  size_t pos() const { return pos_; }
  size_t remaining() const { return end_ - pos_; }
  void set_end(size_t e) { end_ = e; }
  const char* data() const { return bytes_.data() + pos_; }
  void skip(size_t n) { pos_ += n; }

 private:
  std::string_view bytes_;
  const std::string& name_;
  size_t pos_ = 0;
  size_t end_ = bytes_.size();
};

}  // namespace

uint32_t crc32(std::string_view bytes, uint32_t crc) {
  static const std::array<uint32_t, 256> table = make_crc_table();
  crc = ~crc;
  for (char ch : bytes) crc = table[(crc ^ static_cast<uint8_t>(ch)) & 0xffu] ^ (crc >> 8);
  return ~crc;
}

std::string world_to_bytes(const VoxelGrid& grid) {
  std::string out;
  out.reserve(kWorldHeaderBytes + grid.brick_count() * kBrickFixedBytes + grid.voxel_count() * 3 + 4);
  out.append(kMagic, 4);
  put<uint32_t>(out, kWorldFileVersion);
  for (int a = 0; a < 3; ++a) put<double>(out, grid.origin()[a]);
  put<double>(out, grid.voxel_size());
  put<uint64_t>(out, grid.brick_count());
  for (uint32_t bi : grid.sorted_brick_order()) {
    const Brick& b = grid.bricks()[bi];
    for (int a = 0; a < 3; ++a) put<int32_t>(out, b.coord[a]);
    for (uint64_t w : b.mask) put<uint64_t>(out, w);
    for (size_t w = 0; w < 8; ++w)
      for (uint64_t bits = b.mask[w]; bits; bits &= bits - 1)
        put<uint8_t>(out, b.classes[w * 64 + static_cast<size_t>(std::countr_zero(bits))]);
    for (size_t w = 0; w < 8; ++w)
      for (uint64_t bits = b.mask[w]; bits; bits &= bits - 1)
        put<uint16_t>(out, b.instances[w * 64 + static_cast<size_t>(std::countr_zero(bits))]);
  }
  put<uint32_t>(out, crc32(out));
  return out;
}

VoxelGrid world_from_bytes(std::string_view bytes, const std::string& name) {
  Reader r(bytes, name);
  if (bytes.size() < 4 || std::memcmp(bytes.data(), kMagic, 4) != 0)
    r.fail_at(0, "not an icube world file (magic is not \"ICW1\")");
  r.skip(4);
  const uint32_t version = r.get<uint32_t>("version");
  if (version != kWorldFileVersion)
    r.fail_at(4, "unsupported .icw version " + std::to_string(version) + " (this build reads version " +
                     std::to_string(kWorldFileVersion) + ")");
  if (bytes.size() < kWorldHeaderBytes + 4)
    r.fail_at(bytes.size(), "truncated: " + std::to_string(bytes.size()) + " bytes is shorter than the " +
                                std::to_string(kWorldHeaderBytes + 4) + "-byte header and checksum");
  const size_t crc_at = bytes.size() - 4;
  uint32_t stored = 0;
  std::memcpy(&stored, bytes.data() + crc_at, 4);
  const uint32_t actual = crc32(bytes.substr(0, crc_at));
  if (stored != actual) {
    char msg[128];
    std::snprintf(msg, sizeof msg, "CRC32 mismatch (stored %08x, computed %08x): the file is corrupt or truncated",
                  stored, actual);
    r.fail_at(crc_at, msg);
  }
  r.set_end(crc_at);

  glm::dvec3 origin;
  for (int a = 0; a < 3; ++a) origin[a] = r.get<double>("origin");
  const size_t vs_at = r.pos();
  const double vs = r.get<double>("voxel size");
  if (!std::isfinite(origin.x) || !std::isfinite(origin.y) || !std::isfinite(origin.z))
    r.fail_at(8, "origin is not finite");
  if (!(vs > 0.0) || !std::isfinite(vs)) r.fail_at(vs_at, "voxel size must be a positive number");
  const size_t count_at = r.pos();
  const uint64_t brick_count = r.get<uint64_t>("brick count");
  if (brick_count > r.remaining() / (kBrickFixedBytes + 3))  // every brick holds at least one voxel
    r.fail_at(count_at, "brick count " + std::to_string(brick_count) + " exceeds what " +
                            std::to_string(r.remaining()) + " remaining bytes can hold");

  VoxelGrid grid(origin, vs);
  Brick b;
  for (uint64_t i = 0; i < brick_count; ++i) {
    const size_t brick_at = r.pos();
    b = Brick{};
    for (int a = 0; a < 3; ++a) b.coord[a] = r.get<int32_t>("brick coordinate");
    // [-2^20, 2^20) per axis is exactly the bricks of the valid ijk range.
    if (b.coord.x < -kBrickCoordBias || b.coord.y < -kBrickCoordBias || b.coord.z < -kBrickCoordBias ||
        b.coord.x >= kBrickCoordBias || b.coord.y >= kBrickCoordBias || b.coord.z >= kBrickCoordBias)
      r.fail_at(brick_at, "brick " + std::to_string(i) + ": coordinate outside +-2^20");
    for (auto& w : b.mask) w = r.get<uint64_t>("occupancy mask");
    const int n = b.count();
    if (n == 0) r.fail_at(brick_at, "brick " + std::to_string(i) + " is empty");
    r.need(static_cast<size_t>(n) * 3, "brick voxels");
    const size_t classes_at = r.pos();
    const char* cls = r.data();
    const char* inst = cls + n;
    int k = 0;
    for (size_t w = 0; w < 8; ++w)
      for (uint64_t bits = b.mask[w]; bits; bits &= bits - 1, ++k) {
        const size_t bit = w * 64 + static_cast<size_t>(std::countr_zero(bits));
        const uint8_t c = static_cast<uint8_t>(cls[k]);
        if (c == 0 || c >= kNumSemanticClasses)
          r.fail_at(classes_at + static_cast<size_t>(k),
                    "brick " + std::to_string(i) + ": class id " + std::to_string(c) + " is outside 1..22");
        b.classes[bit] = c;
        uint16_t id;
        std::memcpy(&id, inst + 2 * k, 2);
        b.instances[bit] = id;
      }
    r.skip(static_cast<size_t>(n) * 3);
    if (grid.find_brick(b.coord)) r.fail_at(brick_at, "brick " + std::to_string(i) + " appears twice");
    grid.insert_brick(b);
  }
  if (r.remaining() != 0)
    r.fail(std::to_string(r.remaining()) + " unexpected bytes after the last brick");
  return grid;
}

void save_world(const VoxelGrid& grid, const std::string& path) { scene::write_file_atomic(path, world_to_bytes(grid)); }

VoxelGrid load_world(const std::string& path) { return world_from_bytes(scene::read_file(path), path); }

}  // namespace icube::world

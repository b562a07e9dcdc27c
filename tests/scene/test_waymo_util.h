// Helpers shared by the Waymo reader tests (test_waymo_reader.cpp,
// test_waymo_wire.cpp): a tiny protobuf encoder `Pb` for hand-built messages,
// Waymo message builders (map points, object states, polylines, a small
// scenario), TFRecord framing, temporary files under /tmp, the real
// one-scenario file from ../shared/data and InputError capture.
#pragma once

#include "gpu_test_context.h"
#include "scene/atomic_file.h"
#include "scene/input_error.h"
#include "scene/tfrecord.h"
#include "scene/waymo_reader.h"

#include <bit>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <string>
#include <unistd.h>

namespace icube::test::waymo_util {

// ---- a tiny protobuf encoder for hand-built messages ---------------------------

struct Pb {
  std::string b;

  Pb& raw(const std::string& s) {
    b += s;
    return *this;
  }
  Pb& varint(uint64_t v) {
    while (v >= 0x80) {
      b += char(uint8_t(v | 0x80));
      v >>= 7;
    }
    b += char(uint8_t(v));
    return *this;
  }
  Pb& key(uint32_t field, int wire_type) { return varint(uint64_t(field) << 3 | uint64_t(wire_type)); }
  Pb& fixed(uint64_t v, int bytes) {
    for (int i = 0; i < bytes; ++i) b += char(uint8_t(v >> (8 * i)));
    return *this;
  }
  Pb& u(uint32_t field, uint64_t v) { return key(field, 0).varint(v); }
  Pb& i(uint32_t field, int64_t v) { return u(field, static_cast<uint64_t>(v)); }
  Pb& d(uint32_t field, double v) { return key(field, 1).fixed(std::bit_cast<uint64_t>(v), 8); }
  Pb& f(uint32_t field, float v) { return key(field, 5).fixed(std::bit_cast<uint32_t>(v), 4); }
  Pb& s(uint32_t field, const std::string& bytes) { return key(field, 2).varint(bytes.size()).raw(bytes); }
  Pb& m(uint32_t field, const Pb& msg) { return s(field, msg.b); }
};

inline const uint8_t* u8(const std::string& s) { return reinterpret_cast<const uint8_t*>(s.data()); }

inline Pb map_point(double x, double y, double z) { return Pb().d(1, x).d(2, y).d(3, z); }

inline Pb object_state(double x, double y, double z, float heading, bool valid, float height = 1.5f) {
  return Pb().d(2, x).d(3, y).d(4, z).f(5, 4.5f).f(6, 2.0f).f(7, height).f(8, heading).f(9, 1.0f).f(10, 0.0f).u(
      11, valid ? 1 : 0);
}

inline Pb polyline_feature(int64_t id, uint32_t kind_field, uint32_t points_field, int n, double z = -185.0) {
  Pb geom;
  for (int k = 0; k < n; ++k) geom.m(points_field, map_point(10.0 * k, 1.0 * k, z));
  return Pb().i(1, id).m(kind_field, geom);
}

// A small valid scenario: 3 timestamps, a moving SDC (track 7) and a parked
// pedestrian (track 3), a lane, a road line, a road edge, a crosswalk, a stop sign.
inline Pb small_scenario(const std::string& id) {
  Pb sc;
  for (double t : {0.0, 0.1, 0.2}) sc.d(1, t);
  Pb car, ped;
  car.i(1, 7).u(2, 1);
  for (int k = 0; k < 3; ++k) car.m(3, object_state(100.0 + k, 50.0, -184.0, 0.5f, true));
  ped.i(1, 3).u(2, 2);
  for (int k = 0; k < 3; ++k) ped.m(3, object_state(20.0, 30.0, -185.0, -1.0f, true, 1.8f));
  sc.m(2, car).m(2, ped).s(5, id).u(6, 0).u(10, 1);
  Pb lane;
  lane.d(1, 25.0).u(2, 2).u(3, 0).m(8, map_point(0, 0, -185)).m(8, map_point(5, 0, -185));
  lane.s(9, Pb().varint(11).varint(12).b);     // entry_lanes packed
  lane.u(10, 13).u(10, 14);                     // exit_lanes unpacked
  lane.m(11, Pb().i(1, 21).u(2, 0).u(3, 1));    // left neighbour
  lane.m(12, Pb().i(1, 22));                    // right neighbour
  sc.m(8, Pb().i(1, 100).m(3, lane));
  sc.m(8, Pb().i(1, 101).m(4, Pb().u(1, 6).m(2, map_point(0, 1, -185)).m(2, map_point(5, 1, -185))));
  sc.m(8, Pb().i(1, 102).m(5, Pb().u(1, 1).m(2, map_point(0, 2, -185)).m(2, map_point(5, 2, -185))));
  sc.m(8, polyline_feature(103, 8, 1, 4));
  sc.m(8, Pb().i(1, 104).m(7, Pb().i(1, 100).i(1, 101).m(2, map_point(5, -1, -185))));
  return sc;
}

inline std::string frame_record(const std::string& payload) {
  Pb r;
  r.fixed(payload.size(), 8);
  r.fixed(scene::mask_crc32c(scene::crc32c(u8(r.b), 8)), 4);
  r.raw(payload);
  r.fixed(scene::mask_crc32c(scene::crc32c(u8(payload), payload.size())), 4);
  return r.b;
}

struct TempFile {
  std::string path;
  explicit TempFile(const std::string& name, const std::string& bytes)
      : path("/tmp/icube-test-waymo-" + std::to_string(::getpid()) + "-" + name) {
    scene::write_file_atomic(path, bytes);
  }
  ~TempFile() { std::remove(path.c_str()); }
  TempFile(const TempFile&) = delete;
  TempFile& operator=(const TempFile&) = delete;
};

inline std::string real_file_path() { return test_data_file("maps/waymo/motion_data_one_scenario.tfrecord"); }

// The error message of `fn`, or "" if it did not throw InputError.
template <class F>
inline std::string input_error(F&& fn) {
  try {
    fn();
  } catch (const scene::InputError& e) {
    return e.what();
  }
  return {};
}

inline bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

inline scene::Scene parse(const Pb& sc, scene::Diagnostics* diag = nullptr) {
  return scene::parse_waymo_scenario(u8(sc.b), sc.b.size(), "test.pb", "payload", diag);
}

}  // namespace icube::test::waymo_util

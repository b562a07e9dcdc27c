// Waymo Open Motion Dataset reader (engine/scene/waymo_reader.h) and its
// parts: CRC32C and TFRecord framing (tfrecord.h), the protobuf wire reader
// (protobuf_wire.h). Hand-built byte strings cover the wire-format edge cases
// and synthetic multi-record files; the real one-scenario file from
// ../shared/data (skipped when absent) checks counts against PROVENANCE.md.
// Temporary files go to /tmp and are removed.
#include <doctest/doctest.h>

#include "gpu_test_context.h"
#include "scene/atomic_file.h"
#include "scene/protobuf_wire.h"
#include "scene/tfrecord.h"
#include "scene/waymo_reader.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <set>
#include <string>
#include <unistd.h>
#include <vector>

using namespace icube::scene;

namespace {

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

const uint8_t* u8(const std::string& s) { return reinterpret_cast<const uint8_t*>(s.data()); }

Pb map_point(double x, double y, double z) { return Pb().d(1, x).d(2, y).d(3, z); }

Pb object_state(double x, double y, double z, float heading, bool valid, float height = 1.5f) {
  return Pb().d(2, x).d(3, y).d(4, z).f(5, 4.5f).f(6, 2.0f).f(7, height).f(8, heading).f(9, 1.0f).f(10, 0.0f).u(
      11, valid ? 1 : 0);
}

Pb polyline_feature(int64_t id, uint32_t kind_field, uint32_t points_field, int n, double z = -185.0) {
  Pb geom;
  for (int k = 0; k < n; ++k) geom.m(points_field, map_point(10.0 * k, 1.0 * k, z));
  return Pb().i(1, id).m(kind_field, geom);
}

// A small valid scenario: 3 timestamps, a moving SDC (track 7) and a parked
// pedestrian (track 3), a lane, a road line, a road edge, a crosswalk, a stop sign.
Pb small_scenario(const std::string& id) {
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

std::string frame_record(const std::string& payload) {
  Pb r;
  r.fixed(payload.size(), 8);
  r.fixed(mask_crc32c(crc32c(u8(r.b), 8)), 4);
  r.raw(payload);
  r.fixed(mask_crc32c(crc32c(u8(payload), payload.size())), 4);
  return r.b;
}

struct TempFile {
  std::string path;
  explicit TempFile(const std::string& name, const std::string& bytes)
      : path("/tmp/icube-test-waymo-" + std::to_string(::getpid()) + "-" + name) {
    write_file_atomic(path, bytes);
  }
  ~TempFile() { std::remove(path.c_str()); }
  TempFile(const TempFile&) = delete;
  TempFile& operator=(const TempFile&) = delete;
};

std::string real_file_path() {
  const std::string dir = icube::test::test_data_dir();
  if (dir.empty()) return {};
  const std::string p = dir + "/maps/waymo/motion_data_one_scenario.tfrecord";
  return std::filesystem::exists(p) ? p : std::string();
}

// The error message of `fn`, or "" if it did not throw InputError.
template <class F>
std::string input_error(F&& fn) {
  try {
    fn();
  } catch (const InputError& e) {
    return e.what();
  }
  return {};
}

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

Scene parse(const Pb& sc, Diagnostics* diag = nullptr) {
  return parse_waymo_scenario(u8(sc.b), sc.b.size(), "test.pb", "payload", diag);
}

}  // namespace

// ---- CRC32C and framing ------------------------------------------------------------

TEST_CASE("waymo: CRC32C check values and mask") {
  const std::string check = "123456789";
  CHECK(crc32c(u8(check), check.size()) == 0xE3069283u);
  CHECK(crc32c(nullptr, 0) == 0u);
  // RFC 3720 B.4 vectors: 32 bytes of zeros, ones and 0..31 (exercise the 8-byte path).
  std::string zeros(32, '\0'), ones(32, '\xff'), ramp(32, '\0');
  for (int k = 0; k < 32; ++k) ramp[size_t(k)] = char(k);
  CHECK(crc32c(u8(zeros), 32) == 0x8A9136AAu);
  CHECK(crc32c(u8(ones), 32) == 0x62A8AB43u);
  CHECK(crc32c(u8(ramp), 32) == 0x46DD794Eu);
  // Continuing from a previous value equals one pass, for every split point.
  for (size_t split = 0; split <= ramp.size(); ++split)
    CHECK(crc32c(u8(ramp) + split, 32 - split, crc32c(u8(ramp), split)) == 0x46DD794Eu);
  CHECK(mask_crc32c(0) == 0xA282EAD8u);
  CHECK(mask_crc32c(0x00008000u) == 0xA282EAD9u);  // bit 15 rotates to bit 0
}

TEST_CASE("waymo: TFRecord framing of back-to-back records and its errors") {
  const std::string a = "first", b = "", c(300, 'x');
  const std::string file = frame_record(a) + frame_record(b) + frame_record(c);
  auto spans = frame_tfrecords(u8(file), file.size(), "f.tfrecord");
  REQUIRE(spans.size() == 3);
  CHECK(spans[0].offset == 0);
  CHECK(spans[0].payload_offset == 12);
  CHECK(spans[0].length == 5);
  CHECK(spans[1].offset == 21);
  CHECK(spans[1].length == 0);
  CHECK(spans[2].offset == 37);
  CHECK(spans[2].length == 300);
  CHECK(frame_tfrecords(u8(file), 0, "f.tfrecord").empty());

  // Length larger than the file (CRC of the length made valid so the length check is reached).
  Pb huge;
  huge.fixed(1ull << 40, 8);
  huge.fixed(mask_crc32c(crc32c(u8(huge.b), 8)), 4).raw("abcd");
  std::string e = input_error([&] { frame_tfrecords(u8(huge.b), huge.b.size(), "h.tfrecord"); });
  CHECK(contains(e, "h.tfrecord: record 0 at byte 0: length 1099511627776 exceeds"));
  e = input_error([&] { frame_tfrecords(u8(file), file.size() - 2, "f.tfrecord"); });
  CHECK(contains(e, "record 2 at byte 37: truncated record: payload CRC missing (2 of 4 bytes)"));
  e = input_error([&] { frame_tfrecords(u8(file), 40, "f.tfrecord"); });
  CHECK(contains(e, "record 2 at byte 37: truncated record header (3 of 12 bytes)"));
  std::string bad = file;
  bad[21 + 8] ^= 1;  // length CRC of record 1
  e = input_error([&] { frame_tfrecords(u8(bad), bad.size(), "f.tfrecord"); });
  CHECK(contains(e, "record 1 at byte 21: length CRC32C mismatch"));
  bad = file;
  bad[37 + 12 + 150] ^= 0x40;  // payload of record 2
  e = input_error([&] { frame_tfrecords(u8(bad), bad.size(), "f.tfrecord"); });
  CHECK(contains(e, "record 2 at byte 37: payload CRC32C mismatch"));
  // Without payload checks the framing alone succeeds.
  CHECK(frame_tfrecords(u8(bad), bad.size(), "f.tfrecord", {true, false}).size() == 3);
}

// ---- protobuf wire reader ----------------------------------------------------------

TEST_CASE("waymo: protobuf packed and unpacked repeated doubles and varints decode alike") {
  const std::vector<double> want = {0.0, 0.1, -2.5, 1e300, -0.0};
  Pb unpacked, packed_body, packed, vu, vp;
  for (double v : want) {
    unpacked.d(1, v);
    packed_body.fixed(std::bit_cast<uint64_t>(v), 8);
  }
  packed.s(1, packed_body.b);
  const std::vector<int64_t> ints = {0, 1, 300, -1, std::numeric_limits<int64_t>::min()};
  Pb ints_body;
  for (int64_t v : ints) {
    vu.i(2, v);
    ints_body.varint(static_cast<uint64_t>(v));
  }
  vp.s(2, ints_body.b);
  const WireOrigin origin{"t", "", 0, "M"};
  for (const Pb* msg : {&unpacked, &packed}) {
    std::vector<double> got;
    WireReader r(u8(msg->b), msg->b.size(), origin);
    while (r.next()) r.repeated_double(got);
    REQUIRE(got.size() == want.size());
    for (size_t k = 0; k < want.size(); ++k) CHECK(std::bit_cast<uint64_t>(got[k]) == std::bit_cast<uint64_t>(want[k]));
  }
  for (const Pb* msg : {&vu, &vp}) {
    std::vector<int64_t> got;
    WireReader r(u8(msg->b), msg->b.size(), origin);
    while (r.next()) r.repeated_int64(got);
    CHECK(got == ints);
  }
  // Mixed: packed and unpacked pieces of the same field append in order.
  Pb mixed = Pb().d(1, 1.0).raw(packed.b).d(1, 2.0);
  std::vector<double> got;
  WireReader r(u8(mixed.b), mixed.b.size(), origin);
  while (r.next()) r.repeated_double(got);
  CHECK(got.size() == want.size() + 2);
  CHECK(got.front() == 1.0);
  CHECK(got.back() == 2.0);
  // Packed doubles whose length is no multiple of 8.
  Pb odd = Pb().s(1, std::string(12, '\0'));
  std::string e = input_error([&] {
    WireReader q(u8(odd.b), odd.b.size(), origin);
    std::vector<double> v;
    while (q.next()) q.repeated_double(v);
  });
  CHECK(contains(e, "packed doubles: length 12 is not a multiple of 8"));
}

TEST_CASE("waymo: protobuf unknown fields of every wire type are skipped") {
  Pb group_body = Pb().u(1, 5).d(2, 1.0).s(3, "abc").f(4, 2.0f);
  group_body.key(9, 3).u(1, 1).key(9, 4);  // a nested group inside the group
  Pb unknown;                               // field numbers unused by every Waymo message read here
  unknown.u(100, 12345).d(101, 3.0).s(102, "skip me").key(103, 3).raw(group_body.b).key(103, 4).f(105, 1.0f);
  unknown.u(536870911, 1);  // the largest field number
  const Pb msg = Pb(unknown).d(1, 42.0).raw(unknown.b);
  const WireOrigin origin{"t", "", 0, "M"};
  WireReader r(u8(msg.b), msg.b.size(), origin);
  std::vector<uint32_t> fields;
  double value = 0.0;
  while (r.next()) {
    fields.push_back(r.field());
    if (r.field() == 1) value = r.float64();
  }
  const std::vector<uint32_t> once = {100, 101, 102, 103, 105, 536870911};
  std::vector<uint32_t> want = once;
  want.push_back(1);
  want.insert(want.end(), once.begin(), once.end());
  CHECK(fields == want);
  CHECK(value == 42.0);

  // The same unknown fields around and inside every message of a scenario change nothing.
  auto build = [&](const std::string& noise) {
    Pb state = Pb().raw(noise).raw(object_state(1, 2, 3, 0.5f, true).b).raw(noise);
    Pb track = Pb().raw(noise).i(1, 5).raw(noise).u(2, 3).m(3, state).m(3, state).raw(noise);
    Pb point = Pb().raw(noise).raw(map_point(1, 2, 3).b).raw(noise);
    Pb lane = Pb().raw(noise).m(8, point).raw(noise).m(8, point).u(10, 4).raw(noise);
    Pb feature = Pb().raw(noise).i(1, 9).m(3, lane).raw(noise);
    return Pb().raw(noise).d(1, 0.0).raw(noise).d(1, 0.1).m(2, track).s(5, "unk").m(8, feature).u(6, 0).raw(noise);
  };
  Scene a = parse(build("")), b = parse(build(unknown.b));
  CHECK(b.provenance.scenario_id == "unk");
  CHECK(b.timestamps == a.timestamps);
  REQUIRE(b.tracks.size() == 1);
  CHECK(b.tracks[0].id == 5);
  CHECK(b.tracks[0].type == ObjectType::Cyclist);
  REQUIRE(b.tracks[0].states.size() == 2);
  CHECK(b.tracks[0].states[1].center == glm::dvec3(1, 2, 3));
  CHECK(b.tracks[0].states[1].heading == a.tracks[0].states[1].heading);
  REQUIRE(b.map.lanes.size() == 1);
  CHECK(b.map.lanes[0].points == a.map.lanes[0].points);
  CHECK(b.map.lanes[0].exit_lanes == std::vector<int64_t>{4});
}

TEST_CASE("waymo: protobuf fields in descending order decode like ascending ones") {
  auto scenario_with = [](const Pb& point_a, const Pb& point_b, const Pb& state) {
    Pb sc;
    sc.d(1, 0.0).m(2, Pb().m(3, state).u(2, 1).i(1, 9)).u(6, 0).s(5, "order");
    sc.m(8, Pb().m(5, Pb().m(2, point_a).m(2, point_b).u(1, 2)).i(1, 77));  // id after geometry
    return sc;
  };
  Pb asc = scenario_with(map_point(1.5, 2.5, -184.25), map_point(3, 4, -184), object_state(1, 2, 3, 0.25f, true));
  Pb desc_state = Pb().u(11, 1).f(10, 0.0f).f(9, 1.0f).f(8, 0.25f).f(7, 1.5f).f(6, 2.0f).f(5, 4.5f).d(4, 3).d(3, 2).d(2, 1);
  Pb desc = scenario_with(Pb().d(3, -184.25).d(2, 2.5).d(1, 1.5), Pb().d(3, -184).d(2, 4).d(1, 3), desc_state);
  Scene a = parse(asc), b = parse(desc);
  REQUIRE(b.map.road_edges.size() == 1);
  CHECK(b.map.road_edges[0].id == 77);
  CHECK(b.map.road_edges[0].type == RoadEdgeType::Median);
  CHECK(b.map.road_edges[0].points == a.map.road_edges[0].points);
  CHECK(b.map.road_edges[0].points[0] == glm::dvec3(1.5, 2.5, -184.25));
  REQUIRE(b.tracks.size() == 1);
  const BoxState &sa = a.tracks[0].states[0], &sb = b.tracks[0].states[0];
  CHECK(sb.center == glm::dvec3(1, 2, 3));
  CHECK(sb.center == sa.center);
  CHECK(sb.length == 4.5);
  CHECK(sb.width == 2.0);
  CHECK(sb.height == 1.5);
  CHECK(sb.heading == 0.25);
  CHECK(sb.velocity == glm::dvec2(1.0, 0.0));
  CHECK(sb.valid);
  CHECK(b.tracks[0].id == 9);
  CHECK(b.tracks[0].type == ObjectType::Vehicle);
}

TEST_CASE("waymo: protobuf 10-byte negative varints") {
  Pb msg = Pb().i(1, -1).i(2, std::numeric_limits<int64_t>::min()).i(3, -2);
  // Negative int32/int64 values take 10 bytes on the wire.
  CHECK(msg.b.size() == 3 * 11);
  const WireOrigin origin{"t", "", 0, "M"};
  WireReader r(u8(msg.b), msg.b.size(), origin);
  REQUIRE(r.next());
  CHECK(r.int32() == -1);
  CHECK(r.int64() == -1);
  REQUIRE(r.next());
  CHECK(r.int64() == std::numeric_limits<int64_t>::min());
  REQUIRE(r.next());
  CHECK(r.int32() == -2);
  CHECK(!r.next());

  // A negative track id survives; a negative sdc_track_index is out of range.
  Pb sc = Pb().d(1, 0.0).m(2, Pb().i(1, -5).m(3, object_state(0, 0, 0, 0, true)));
  Scene s = parse(Pb(sc).u(6, 0));
  CHECK(s.tracks[0].id == -5);
  std::string e = input_error([&] { parse(Pb(sc).i(6, -1)); });
  CHECK(contains(e, "test.pb: payload, sdc_track_index: -1 is out of range (1 tracks)"));
}

TEST_CASE("waymo: protobuf 11-byte varint is an error naming the byte") {
  Pb msg = Pb().d(1, 1.0).key(2, 0).raw(std::string(10, '\x80')).raw("\x01");
  const WireOrigin origin{"f.tfrecord", "record 4", 1000, "Scenario"};
  std::string e = input_error([&] {
    WireReader r(u8(msg.b), msg.b.size(), origin);
    while (r.next()) {
    }
  });
  CHECK(e == "f.tfrecord: record 4 at byte 1010, in Scenario: value: varint longer than 10 bytes");
  // A varint cut off by the end of the message.
  Pb cut = Pb().key(2, 0).raw("\x80\x80");
  e = input_error([&] {
    WireReader r(u8(cut.b), cut.b.size(), origin);
    while (r.next()) {
    }
  });
  CHECK(e == "f.tfrecord: record 4 at byte 1001, in Scenario: value: varint runs past the end (2 bytes left)");
}

TEST_CASE("waymo: protobuf LEN past the end, bad wire types and groups are errors") {
  const WireOrigin origin{"f.tfrecord", "record 0", 12, "Scenario"};
  auto walk = [&](const Pb& msg) {
    return input_error([&] {
      WireReader r(u8(msg.b), msg.b.size(), origin);
      while (r.next()) {
      }
    });
  };
  CHECK(contains(walk(Pb().d(1, 0.0).key(8, 2).varint(50).raw("short")),
                 "f.tfrecord: record 0 at byte 21, in Scenario: field 8 (LEN): length 50 runs past the end of the "
                 "message (5 bytes left)"));
  CHECK(contains(walk(Pb().key(3, 6)), "at byte 12, in Scenario: invalid wire type 6"));
  CHECK(contains(walk(Pb().key(3, 7).u(1, 1)), "invalid wire type 7"));
  CHECK(contains(walk(Pb().key(3, 4)), "end-group without a matching start-group"));
  CHECK(contains(walk(Pb().key(3, 3).u(1, 1)), "group is not closed"));
  CHECK(contains(walk(Pb().key(3, 3).key(4, 4)), "end-group for field 4 closes group 3"));
  CHECK(contains(walk(Pb().u(0, 1)), "invalid field number 0"));
  CHECK(contains(walk(Pb().d(1, 0.0).raw("\x09\x01\x02")), "8-byte value runs past the end"));
  Pb deep;
  for (int k = 0; k < 100; ++k) deep.key(5, 3);
  CHECK(contains(walk(deep), "groups nested deeper than 64"));
  // A known field with the wrong wire type, inside a sub-message: the path names it.
  Pb sc = Pb().m(2, Pb().m(3, Pb().u(2, 7)));  // center_x as a varint
  std::string e = input_error([&] { parse(sc); });
  CHECK(contains(e, "test.pb: payload at byte 4, in Scenario.tracks[0].states[0]: field 2 (VARINT): wrong wire type, "
                    "expected I64"));
  // LEN past the end of a nested message (but inside the outer one).
  Pb nested = Pb().m(8, Pb().i(1, 3).key(3, 2).varint(9)).s(5, std::string(20, 'z'));
  e = input_error([&] { parse(nested); });
  CHECK(contains(e, "in Scenario.map_features[0]: field 3 (LEN): length 9 runs past the end of the message (0 bytes left)"));
}

TEST_CASE("waymo: protobuf sub-message nesting is limited") {
  // 70 nested LEN fields: the schema-free walk below descends through all of them.
  std::string body;
  for (int k = 0; k < 70; ++k) body = Pb().s(1, body).b;
  const WireOrigin origin{"t", "", 0, "M"};
  std::string e = input_error([&] {
    WireReader root(u8(body), body.size(), origin);
    std::vector<WireReader> chain{root};
    chain.reserve(80);  // readers point at their parents: no reallocation
    while (chain.back().next()) chain.push_back(chain.back().message("m"));
  });
  CHECK(contains(e, "messages nested deeper than 64"));
}

// ---- scenario semantics on hand-built messages -----------------------------------------

TEST_CASE("waymo: small hand-built scenario decodes every field") {
  Diagnostics diag;
  Scene s = parse(small_scenario("abc"), &diag);
  CHECK(diag.warnings.empty());
  CHECK(s.provenance.scenario_id == "abc");
  CHECK(s.provenance.source_format == "waymo-scenario");
  CHECK(s.provenance.source_file == "test.pb");
  CHECK(s.timestamps == std::vector<double>{0.0, 0.1, 0.2});
  CHECK(s.current_time_index == 1);
  REQUIRE(s.tracks.size() == 2);
  CHECK(s.sdc_track_index == 0);
  CHECK(s.tracks[0].type == ObjectType::Vehicle);
  CHECK(s.tracks[1].type == ObjectType::Pedestrian);
  CHECK(s.tracks[0].dynamic);
  CHECK(!s.tracks[1].dynamic);
  CHECK(s.tracks[0].instance_id == kFirstDynamicInstanceId);
  CHECK(s.tracks[1].instance_id == kFirstStaticInstanceId);
  REQUIRE(s.map.lanes.size() == 1);
  const Lane& lane = s.map.lanes[0];
  CHECK(lane.id == 100);
  CHECK(lane.type == LaneType::SurfaceStreet);
  CHECK(lane.speed_limit_mph == 25.0);
  CHECK(!lane.interpolating);
  CHECK(lane.points.size() == 2);
  CHECK(lane.entry_lanes == std::vector<int64_t>{11, 12});
  CHECK(lane.exit_lanes == std::vector<int64_t>{13, 14});
  CHECK(lane.left_neighbors == std::vector<int64_t>{21});
  CHECK(lane.right_neighbors == std::vector<int64_t>{22});
  REQUIRE(s.map.road_lines.size() == 1);
  CHECK(s.map.road_lines[0].type == RoadLineType::SolidSingleYellow);
  REQUIRE(s.map.road_edges.size() == 1);
  CHECK(s.map.road_edges[0].type == RoadEdgeType::Boundary);
  REQUIRE(s.map.crosswalks.size() == 1);
  CHECK(s.map.crosswalks[0].points.size() == 4);
  REQUIRE(s.map.stop_signs.size() == 1);
  CHECK(s.map.stop_signs[0].lanes == std::vector<int64_t>{100, 101});
  CHECK(s.map.stop_signs[0].position == glm::dvec3(5, -1, -185));
  CHECK(s.missing == std::vector<std::string>{"cameras"});
}

TEST_CASE("waymo: ego poses come from the SDC box, on the ground below its centre") {
  Scene s = parse(small_scenario("ego"));
  REQUIRE(s.ego.size() == 3);
  for (size_t k = 0; k < 3; ++k) {
    const glm::dmat4& m = s.ego[k].ego_to_world;
    CHECK(s.ego[k].valid);
    // Origin: centre minus half the height (1.5 m box at z = -184).
    CHECK(m[3] == glm::dvec4(100.0 + double(k), 50.0, -184.75, 1.0));
    // x axis along heading 0.5 rad (stored as float), z up.
    const double h = static_cast<double>(0.5f);
    CHECK(m[0][0] == doctest::Approx(std::cos(h)).epsilon(1e-15));
    CHECK(m[0][1] == doctest::Approx(std::sin(h)).epsilon(1e-15));
    CHECK(m[2] == glm::dvec4(0, 0, 1, 0));
    // The ego frame's +x point 1 m ahead lies along the heading.
    const glm::dvec4 ahead = m * glm::dvec4(1, 0, 0, 1);
    CHECK(ahead.x - m[3].x == doctest::Approx(std::cos(h)));
  }
  // An invalid SDC state gives an invalid identity pose.
  Pb sc = Pb().d(1, 0).d(1, 1).m(2, Pb().i(1, 1).m(3, object_state(5, 5, 5, 0, true)).m(3, object_state(9, 9, 9, 0, false)));
  Scene t = parse(sc.u(6, 0));
  REQUIRE(t.ego.size() == 2);
  CHECK(t.ego[0].valid);
  CHECK(!t.ego[1].valid);
  CHECK(t.ego[1].ego_to_world == glm::dmat4(1.0));
}

TEST_CASE("waymo: tracks are padded or truncated to one state per timestamp, with warnings") {
  Pb sc;
  for (int k = 0; k < 4; ++k) sc.d(1, 0.1 * k);
  Pb short_track = Pb().i(1, 1).m(3, object_state(0, 0, 0, 0, true)).m(3, object_state(1, 0, 0, 0, true));
  Pb long_track = Pb().i(1, 2);
  for (int k = 0; k < 6; ++k) long_track.m(3, object_state(double(k), 0, 0, 0, true));
  Pb never_valid = Pb().i(1, 3);
  for (int k = 0; k < 4; ++k) never_valid.m(3, object_state(0, 0, 0, 0, false));
  sc.m(2, short_track).m(2, long_track).m(2, never_valid).u(6, 1).s(5, "pad");
  Diagnostics diag;
  Scene s = parse(sc, &diag);
  REQUIRE(s.tracks.size() == 3);
  for (const Track& t : s.tracks) CHECK(t.states.size() == 4);
  CHECK(s.tracks[0].states[1].valid);
  CHECK(!s.tracks[0].states[2].valid);
  CHECK(!s.tracks[0].states[3].valid);
  CHECK(s.tracks[1].states[3].center.x == 3.0);
  REQUIRE(diag.warnings.size() == 3);
  CHECK(contains(diag.warnings[0], "track 1 (tracks[0]"));
  CHECK(contains(diag.warnings[0], "2 states for 4 timestamps; padded with invalid states"));
  CHECK(contains(diag.warnings[1], "track 2 (tracks[1]"));
  CHECK(contains(diag.warnings[1], "6 states for 4 timestamps; truncated"));
  CHECK(contains(diag.warnings[2], "track 3 (tracks[2]"));
  CHECK(contains(diag.warnings[2], "track has no valid state"));
  CHECK(s.ego.size() == 4);
}

TEST_CASE("waymo: padding is bounded by the input size") {
  // 2,000 timestamps (packed, 16 KB) and 20,000 empty tracks (40 KB) would pad to 40 M states.
  Pb sc, ts;
  for (int k = 0; k < 2000; ++k) ts.fixed(std::bit_cast<uint64_t>(0.1 * k), 8);
  sc.s(1, ts.b);
  for (int k = 0; k < 20000; ++k) sc.s(2, "");
  std::string e = input_error([&] { parse(sc); });
  CHECK(contains(e, "tracks are short of 40000000 states for 2000 timestamps"));
}

TEST_CASE("waymo: NaN and Inf coordinates are errors naming the feature or track and state") {
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  Pb sc = small_scenario("nan");
  Pb bad_map = Pb(sc).m(8, Pb().i(1, 555).m(4, Pb().m(2, map_point(0, 0, 0)).m(2, map_point(1, nan, 0))));
  std::string e = input_error([&] { parse(bad_map); });
  CHECK(contains(e, "test.pb: payload, map feature 555 (map_features[5], road_line, at byte "));
  CHECK(contains(e, "): point 1: y is nan"));
  Pb bad_poly = Pb(sc).m(8, Pb().i(1, 556).m(9, Pb().m(1, map_point(0, 0, 0)).m(1, map_point(1, 0, inf)).m(1, map_point(1, 1, 0))));
  e = input_error([&] { parse(bad_poly); });
  CHECK(contains(e, "map feature 556 (map_features[5], speed_bump"));
  CHECK(contains(e, "point 1: z is inf"));

  Pb track = Pb().i(1, 42);
  track.m(3, object_state(0, 0, 0, 0, true)).m(3, object_state(0, 0, 0, 0, true)).m(3, object_state(nan, 0, 0, 0, true));
  Pb bad_track = Pb(sc).m(2, track);
  e = input_error([&] { parse(bad_track); });
  CHECK(contains(e, "track 42 (tracks[2], at byte "));
  CHECK(contains(e, "state 2 is valid but center_x is nan"));
  // The same values in an invalid state are zeroed, not an error.
  Pb ok_track = Pb().i(1, 43).m(3, object_state(0, 0, 0, 0, true)).m(3, object_state(1, 0, 0, 0, true));
  ok_track.m(3, object_state(nan, 0, 0, 0, false));
  Scene s = parse(Pb(sc).m(2, ok_track));
  CHECK(s.tracks[2].states[2].center.x == 0.0);
  CHECK(!s.tracks[2].states[2].valid);
}

TEST_CASE("waymo: empty polylines and short polygons are dropped, single points kept, with a warning") {
  Pb sc = Pb().d(1, 0).s(5, "drop");
  sc.m(8, polyline_feature(1, 3, 8, 1));   // lane with 1 point
  sc.m(8, polyline_feature(2, 4, 2, 0));   // road line with none
  sc.m(8, polyline_feature(3, 5, 2, 2));   // road edge with 2: kept
  sc.m(8, polyline_feature(4, 8, 1, 2));   // crosswalk with 2
  // A driveway of 3 distinct points plus a closing repeat of the first: kept as 3.
  sc.m(8, Pb().i(1, 5).m(10, Pb().m(1, map_point(0, 0, 0)).m(1, map_point(1, 0, 0)).m(1, map_point(1, 1, 0)).m(1, map_point(0, 0, 0))));
  // Two distinct points plus a repeat: dropped.
  sc.m(8, Pb().i(1, 6).m(9, Pb().m(1, map_point(0, 0, 0)).m(1, map_point(1, 0, 0)).m(1, map_point(0, 0, 0))));
  sc.m(8, Pb().i(1, 7).m(7, Pb().i(1, 3)));  // stop sign without position
  sc.m(8, Pb().i(1, 8));                      // no geometry
  Diagnostics diag;
  Scene s = parse(sc, &diag);
  REQUIRE(s.map.lanes.size() == 1);  // a single point is kept
  CHECK(s.map.lanes[0].points.size() == 1);
  CHECK(s.map.road_lines.empty());
  CHECK(s.map.road_edges.size() == 1);
  CHECK(s.map.crosswalks.empty());
  REQUIRE(s.map.driveways.size() == 1);
  CHECK(s.map.driveways[0].points.size() == 3);
  CHECK(s.map.speed_bumps.empty());
  CHECK(s.map.stop_signs.empty());
  REQUIRE(diag.warnings.size() == 6);
  CHECK(contains(diag.warnings[0], "map feature 1 (map_features[0], lane"));
  CHECK(contains(diag.warnings[0], "polyline has 1 point; kept as a single point"));
  CHECK(contains(diag.warnings[1], "map feature 2 (map_features[1], road_line"));
  CHECK(contains(diag.warnings[1], "polyline has no points; dropped"));
  CHECK(contains(diag.warnings[2], "map feature 4 (map_features[3], crosswalk"));
  CHECK(contains(diag.warnings[3], "map feature 6 (map_features[5], speed_bump"));
  CHECK(contains(diag.warnings[3], "polygon has 2 distinct point(s), needs 3"));
  CHECK(contains(diag.warnings[4], "stop sign has no position"));
  CHECK(contains(diag.warnings[5], "feature has no geometry"));
  // No sdc_track_index and no tracks: both listed as missing.
  CHECK(s.missing == std::vector<std::string>{"ego trajectory", "object boxes", "cameras"});
  CHECK(s.sdc_track_index == -1);
  CHECK(s.ego.empty());
}

TEST_CASE("waymo: warnings are capped at 100 per scenario plus a count") {
  Pb sc = Pb().d(1, 0).s(5, "many");
  for (int k = 0; k < 150; ++k) sc.m(8, polyline_feature(k, 4, 2, 1));  // 150 one-point road lines (kept, warned)
  Diagnostics diag;
  Scene s = parse(sc, &diag);
  CHECK(s.map.road_lines.size() == 150);
  REQUIRE(diag.warnings.size() == 101);
  CHECK(contains(diag.warnings[99], "map feature 99 (map_features[99], road_line"));
  CHECK(diag.warnings[100] == "test.pb: payload: 50 more warnings not shown");
}

TEST_CASE("waymo: oneof geometry merges when repeated and is replaced by another member") {
  Pb sc = Pb().d(1, 0);
  // Lane given twice: points merge, and the later type wins.
  sc.m(8, Pb().i(1, 1).m(3, Pb().u(2, 1).m(8, map_point(0, 0, 0))).m(3, Pb().u(2, 3).m(8, map_point(1, 0, 0))));
  // A road line then a road edge: the edge replaces the line.
  const Pb line = Pb().u(1, 2).m(2, map_point(0, 0, 0)).m(2, map_point(1, 0, 0));
  const Pb edge = Pb().m(2, map_point(0, 0, 0)).m(2, map_point(0, 1, 0));
  sc.m(8, Pb().i(1, 2).m(4, line).m(5, edge));
  Scene s = parse(sc);
  REQUIRE(s.map.lanes.size() == 1);
  CHECK(s.map.lanes[0].points.size() == 2);
  CHECK(s.map.lanes[0].type == LaneType::BikeLane);
  CHECK(s.map.road_lines.empty());
  REQUIRE(s.map.road_edges.size() == 1);
  CHECK(s.map.road_edges[0].id == 2);
}

TEST_CASE("waymo: unknown enum values become 0 with a warning") {
  Pb sc = Pb().d(1, 0).m(2, Pb().i(1, 1).u(2, 9).m(3, object_state(0, 0, 0, 0, true))).u(6, 0).s(5, "enum");
  sc.m(8, Pb().i(1, 5).m(5, Pb().u(1, 3).m(2, map_point(0, 0, 0)).m(2, map_point(1, 0, 0))));
  Diagnostics diag;
  Scene s = parse(sc, &diag);
  CHECK(s.tracks[0].type == ObjectType::Unset);
  CHECK(s.map.road_edges[0].type == RoadEdgeType::Unknown);  // Waymo RoadEdgeType stops at 2
  REQUIRE(diag.warnings.size() == 2);
  CHECK(contains(diag.warnings[0], "in Scenario.tracks[0]: unknown ObjectType 9; using 0"));
  CHECK(contains(diag.warnings[1], "in Scenario.map_features[0].road_edge: unknown RoadEdgeType 3; using 0"));
}

TEST_CASE("waymo: timestamps and current_time_index are validated") {
  std::string e = input_error([&] { parse(Pb().d(1, 0.0).d(1, 0.2).d(1, 0.1)); });
  CHECK(contains(e, "test.pb: payload, timestamps_seconds[2]: timestamp 0.10000000000000001 s is not after the previous "
                    "one (0.20000000000000001 s)"));
  e = input_error([&] { parse(Pb().d(1, std::numeric_limits<double>::quiet_NaN())); });
  CHECK(contains(e, "timestamps_seconds[0]: timestamp is nan"));
  e = input_error([&] { parse(Pb().d(1, 0.0).d(1, 0.1).u(10, 2)); });
  CHECK(contains(e, "payload, current_time_index: 2 is out of range (2 timestamps)"));
  e = input_error([&] { parse(Pb().d(1, 0.0).m(2, Pb().i(1, 4)).u(6, 1)); });
  CHECK(contains(e, "payload, sdc_track_index: 1 is out of range (1 tracks)"));
}

// ---- files ----------------------------------------------------------------------------

TEST_CASE("waymo: a synthetic 3-record file is selected by index and by id") {
  const std::string file = frame_record(small_scenario("alpha").b) + frame_record(small_scenario("bravo").b) +
                           frame_record(small_scenario("1234").b);
  TempFile tmp("three.tfrecord", file);
  auto infos = list_waymo_records(tmp.path);
  REQUIRE(infos.size() == 3);
  CHECK(infos[0].offset == 0);
  CHECK(infos[0].scenario_id == "alpha");
  CHECK(infos[1].offset == infos[0].length + 16);
  CHECK(infos[1].scenario_id == "bravo");
  CHECK(infos[2].scenario_id == "1234");
  CHECK(infos[0].length + infos[1].length + infos[2].length + 48 == file.size());

  CHECK(read_waymo_scenario(tmp.path).provenance.scenario_id == "alpha");
  CHECK(read_waymo_scenario(tmp.path, "1").provenance.scenario_id == "bravo");
  CHECK(read_waymo_scenario(tmp.path, "2").provenance.scenario_id == "1234");
  Scene b = read_waymo_scenario(tmp.path, "bravo");
  CHECK(b.provenance.scenario_id == "bravo");
  CHECK(b.provenance.source_file == tmp.path);
  CHECK(b.tracks.size() == 2);
  CHECK(read_waymo_scenario(tmp.path, "1234").provenance.scenario_id == "1234");  // digits, no valid index: an id

  std::string e = input_error([&] { read_waymo_scenario(tmp.path, "3"); });
  CHECK(contains(e, tmp.path + ": selector '3': record index out of range: the file holds 3 records (indices 0..2)"));
  e = input_error([&] { read_waymo_scenario(tmp.path, "99999999999999999999999"); });
  CHECK(contains(e, "the file holds 3 records"));
  e = input_error([&] { read_waymo_scenario(tmp.path, "charlie"); });
  CHECK(contains(e, "selector 'charlie': no scenario with this id among 3 records: 0:'alpha', 1:'bravo', 2:'1234'"));

  // Errors inside a later record name it with absolute file offsets.
  Pb broken = Pb().s(5, "delta").key(8, 2).varint(100);
  const std::string file2 = file + frame_record(broken.b);
  TempFile tmp2("four.tfrecord", file2);
  e = input_error([&] { read_waymo_scenario(tmp2.path, "3"); });
  const size_t key_offset = file.size() + 12 + 7;
  CHECK(contains(e, tmp2.path + ": record 3 at byte " + std::to_string(key_offset) +
                        ", in Scenario: field 8 (LEN): length 100 runs past the end"));
  CHECK(read_waymo_scenario(tmp2.path, "0").provenance.scenario_id == "alpha");
}

TEST_CASE("waymo: empty and missing files are clear errors") {
  TempFile empty("empty.tfrecord", "");
  CHECK(list_waymo_records(empty.path).empty());
  std::string e = input_error([&] { read_waymo_scenario(empty.path); });
  CHECK(contains(e, empty.path + ": the file holds no TFRecord records"));
  e = input_error([&] { read_waymo_scenario("/tmp/icube-test-waymo-does-not-exist.tfrecord"); });
  CHECK(contains(e, "/tmp/icube-test-waymo-does-not-exist.tfrecord: cannot open"));
}

// ---- the real file ------------------------------------------------------------------------

TEST_CASE("waymo: the real one-scenario file matches its provenance") {
  const std::string path = real_file_path();
  if (path.empty()) {
    MESSAGE("skipped: motion_data_one_scenario.tfrecord not found (set ICUBE_TEST_DATA)");
    return;
  }
  auto infos = list_waymo_records(path);
  REQUIRE(infos.size() == 1);
  CHECK(infos[0].offset == 0);
  CHECK(infos[0].length == 952963 - 16);
  CHECK(infos[0].scenario_id == "637f20cafde22ff8");

  Diagnostics diag;
  const Scene s = read_waymo_scenario(path, "", &diag);
  CHECK(s.provenance.scenario_id == "637f20cafde22ff8");
  CHECK(s.provenance.source_format == "waymo-scenario");
  CHECK(s.provenance.source_file == path);
  REQUIRE(s.tracks.size() == 83);
  int vehicles = 0, pedestrians = 0, cyclists = 0;
  for (const Track& t : s.tracks) {
    vehicles += t.type == ObjectType::Vehicle;
    pedestrians += t.type == ObjectType::Pedestrian;
    cyclists += t.type == ObjectType::Cyclist;
    CHECK(t.states.size() == 91);
  }
  CHECK(vehicles == 70);
  CHECK(pedestrians == 10);
  CHECK(cyclists == 3);
  REQUIRE(s.timestamps.size() == 91);
  CHECK(s.timestamps.front() == doctest::Approx(0.0).epsilon(1e-9));
  for (size_t k = 1; k < s.timestamps.size(); ++k) {
    const double dt = s.timestamps[k] - s.timestamps[k - 1];
    CHECK(dt > 0.099);
    CHECK(dt < 0.101);
  }
  CHECK(s.current_time_index == 10);
  CHECK(s.sdc_track_index == 82);
  // Road line 131 and lane 529 have a single point each: kept, with a warning.
  CHECK(s.map.road_edges.size() == 28);
  CHECK(s.map.road_lines.size() == 59);
  CHECK(s.map.lanes.size() == 199);
  REQUIRE(diag.warnings.size() == 2);
  CHECK(contains(diag.warnings[0], "map feature 131 (map_features[77], road_line, at byte 601555): polyline has 1 point"));
  CHECK(contains(diag.warnings[1], "map feature 529 (map_features[247], lane, at byte 886244): polyline has 1 point"));
  CHECK(s.map.crosswalks.size() == 4);
  CHECK(s.map.speed_bumps.size() == 3);
  CHECK(s.map.driveways.size() == 0);
  CHECK(s.map.stop_signs.size() == 8);

  size_t points = 0;
  double zmin = 1e300, zmax = -1e300;
  auto add = [&](const std::vector<glm::dvec3>& pts) {
    points += pts.size();
    for (const glm::dvec3& p : pts) {
      zmin = std::min(zmin, p.z);
      zmax = std::max(zmax, p.z);
    }
  };
  for (const auto& e : s.map.road_edges) add(e.points);
  for (const auto& l : s.map.road_lines) add(l.points);
  for (const auto& l : s.map.lanes) add(l.points);
  for (const auto& p : s.map.crosswalks) add(p.points);
  for (const auto& p : s.map.speed_bumps) add(p.points);
  // 19,628 polyline and polygon points in the file.
  CHECK(points == 19628);
  // [-186.9, -183.0] m to 0.1 m (lowest -186.928, highest -182.980); stop signs stand higher.
  CHECK(zmin == doctest::Approx(-186.9).epsilon(0.05 / 186.9));
  CHECK(zmax == doctest::Approx(-183.0).epsilon(0.05 / 183.0));
  for (const auto& st : s.map.stop_signs) {
    CHECK(st.position.z > -185.3);
    CHECK(st.position.z < -182.3);
  }

  // Ego: one pose per timestamp from the parked SDC, on the ground below its box centre.
  REQUIRE(s.ego.size() == 91);
  const Track& sdc = s.tracks[82];
  CHECK(!sdc.dynamic);
  for (size_t k = 0; k < 91; ++k) {
    CHECK(s.ego[k].valid == sdc.states[k].valid);
    if (!sdc.states[k].valid) continue;
    const BoxState& b = sdc.states[k];
    CHECK(s.ego[k].ego_to_world[3] == glm::dvec4(b.center.x, b.center.y, b.center.z - 0.5 * b.height, 1.0));
  }
  CHECK(s.ego[10].valid);
  CHECK(s.missing == std::vector<std::string>{"cameras"});

  // Instance ids: unique, statics 1..n, dynamics 10000.. (classify_tracks).
  std::set<uint32_t> statics, dynamics;
  for (const Track& t : s.tracks) (t.dynamic ? dynamics : statics).insert(t.instance_id);
  CHECK(statics.size() + dynamics.size() == 83);
  REQUIRE(!statics.empty());
  REQUIRE(!dynamics.empty());
  CHECK(*statics.begin() == kFirstStaticInstanceId);
  CHECK(*statics.rbegin() == kFirstStaticInstanceId + statics.size() - 1);
  CHECK(*dynamics.begin() == kFirstDynamicInstanceId);
  CHECK(*dynamics.rbegin() == kFirstDynamicInstanceId + dynamics.size() - 1);

  // Index and id selectors reach the same record.
  CHECK(read_waymo_scenario(path, "0").tracks.size() == 83);
  CHECK(read_waymo_scenario(path, "637f20cafde22ff8").map.lanes.size() == 199);
  std::string e = input_error([&] { read_waymo_scenario(path, "1"); });
  CHECK(contains(e, "the file holds 1 record (indices 0..0)"));
  e = input_error([&] { read_waymo_scenario(path, "deadbeef"); });
  CHECK(contains(e, "no scenario with this id among 1 record: 0:'637f20cafde22ff8'"));
}

TEST_CASE("waymo: truncated copies of the real file are errors naming the file and record") {
  const std::string path = real_file_path();
  if (path.empty()) {
    MESSAGE("skipped: motion_data_one_scenario.tfrecord not found (set ICUBE_TEST_DATA)");
    return;
  }
  const std::string bytes = read_file(path);
  for (size_t cut : {size_t(1), size_t(11), size_t(12), size_t(13), size_t(4096), bytes.size() / 2, bytes.size() - 4,
                     bytes.size() - 1}) {
    CAPTURE(cut);
    TempFile tmp("cut.tfrecord", bytes.substr(0, cut));
    const std::string e = input_error([&] { read_waymo_scenario(tmp.path); });
    CHECK(contains(e, tmp.path + ": record 0 at byte 0: "));
    CHECK(contains(e, cut < 12                ? "truncated record header"
                      : cut >= bytes.size() - 4 ? "truncated record: payload CRC missing"
                                                : "exceeds the"));
  }
  // Junk after the last record starts a second, truncated record.
  TempFile extra("extra.tfrecord", bytes + "xyz");
  CHECK(contains(input_error([&] { read_waymo_scenario(extra.path); }),
                 "record 1 at byte 952963: truncated record header (3 of 12 bytes)"));
}

TEST_CASE("waymo: a flipped byte in the real file is a CRC error") {
  const std::string path = real_file_path();
  if (path.empty()) {
    MESSAGE("skipped: motion_data_one_scenario.tfrecord not found (set ICUBE_TEST_DATA)");
    return;
  }
  const std::string bytes = read_file(path);
  for (size_t at : {size_t(12), size_t(500000), bytes.size() - 5}) {
    CAPTURE(at);
    std::string bad = bytes;
    bad[at] = char(bad[at] ^ 0x10);
    TempFile tmp("flip.tfrecord", bad);
    const std::string e = input_error([&] { read_waymo_scenario(tmp.path); });
    CHECK(contains(e, tmp.path + ": record 0 at byte 0: payload CRC32C mismatch"));
    CHECK(contains(input_error([&] { list_waymo_records(tmp.path); }), "payload CRC32C mismatch"));
  }
  std::string bad = bytes;
  bad[2] = char(bad[2] ^ 0x01);  // the length itself
  TempFile tmp("flip-length.tfrecord", bad);
  CHECK(contains(input_error([&] { read_waymo_scenario(tmp.path); }), "record 0 at byte 0: length CRC32C mismatch"));
}

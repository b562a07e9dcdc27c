// Waymo reader parts below the scenario level: CRC32C and TFRecord framing
// (engine/scene/tfrecord.h) and the protobuf wire reader
// (engine/scene/protobuf_wire.h), on hand-built byte strings covering the
// wire-format edge cases. Scenario decoding and files are in
// test_waymo_reader.cpp; the shared helpers in test_waymo_util.h.
#include <doctest/doctest.h>

#include "scene/protobuf_wire.h"
#include "scene/tfrecord.h"
#include "scene/waymo_reader.h"
#include "test_waymo_util.h"

#include <bit>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

using namespace icube::scene;
using namespace icube::test::waymo_util;

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

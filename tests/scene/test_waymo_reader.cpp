// Waymo Open Motion Dataset reader (engine/scene/waymo_reader.h): scenario
// semantics on hand-built messages, synthetic multi-record files and record
// selectors, and the real one-scenario file from ../shared/data (skipped when
// absent), whose counts are checked against PROVENANCE.md. CRC32C, TFRecord
// framing and the protobuf wire reader are tested in test_waymo_wire.cpp; the
// shared helpers (the protobuf encoder `Pb` etc.) are in test_waymo_util.h.
// Temporary files go to /tmp and are removed.
#include <doctest/doctest.h>

#include "scene/atomic_file.h"
#include "scene/waymo_reader.h"
#include "test_waymo_util.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <set>
#include <string>
#include <vector>

using namespace icube::scene;
using namespace icube::test::waymo_util;

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
  CHECK(!s.tracks[0].dynamic);  // the ego (sdc) is not an object: no instance id
  CHECK(!s.tracks[1].dynamic);
  CHECK(s.tracks[0].instance_id == 0);
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

  // Instance ids: unique, statics 1..n, dynamics 10000.. (classify_tracks); the ego is no object (id 0).
  std::set<uint32_t> statics, dynamics;
  REQUIRE(s.sdc_track_index >= 0);
  for (size_t i = 0; i < s.tracks.size(); ++i) {
    const Track& t = s.tracks[i];
    if (is_ego_track(s, i)) {
      CHECK(t.instance_id == 0);
      CHECK(!t.dynamic);
      continue;
    }
    (t.dynamic ? dynamics : statics).insert(t.instance_id);
  }
  CHECK(statics.size() + dynamics.size() == 82);
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

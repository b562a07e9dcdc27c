// The scene model: everything the engine takes in about one driving scene.
//
// HD map features as 3D polylines/polygons, object tracks with per-timestamp
// oriented boxes, the ego (self-driving car) trajectory, cameras, timestamps,
// a text prompt and provenance. All positions are double precision metres in
// one right-handed world frame with z up (the source's world frame: Waymo
// global coordinates, or OpenDRIVE inertial x/y/z). Nothing here is
// chunk-local; later stages subtract an origin in double before going to float.
//
// Readers: scene_json.h (the project's own format, docs/scene-format.md),
// waymo_reader.h (Waymo Open Motion Dataset TFRecords), opendrive_reader.h
// (OpenDRIVE 1.4-1.8). Frame conversions: frames.h.
#pragma once

#include <glm/glm.hpp>

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace icube::scene {

// ---- map ---------------------------------------------------------------------

// Waymo RoadEdgeType; OpenDRIVE drivable/non-drivable borders map to Boundary,
// borders between opposite carriageways to Median, roadMark "curb" to Curb.
enum class RoadEdgeType : int { Unknown = 0, Boundary = 1, Median = 2, Curb = 3 };

// Waymo RoadLineType values 0-8 (same numbers); OpenDRIVE road marks map onto
// them (solid/broken, white/yellow, single/double) and keep their raw type in
// RoadLine::source_type.
enum class RoadLineType : int {
  Unknown = 0,
  BrokenSingleWhite = 1,
  SolidSingleWhite = 2,
  SolidDoubleWhite = 3,
  BrokenSingleYellow = 4,
  BrokenDoubleYellow = 5,
  SolidSingleYellow = 6,
  SolidDoubleYellow = 7,
  PassingDoubleYellow = 8,
};

// Waymo LaneCenter.LaneType (OpenDRIVE driving lanes -> SurfaceStreet, biking -> BikeLane).
enum class LaneType : int { Undefined = 0, Freeway = 1, SurfaceStreet = 2, BikeLane = 3 };

struct RoadEdge {
  int64_t id = 0;
  RoadEdgeType type = RoadEdgeType::Unknown;
  std::vector<glm::dvec3> points;
};

struct RoadLine {
  int64_t id = 0;
  RoadLineType type = RoadLineType::Unknown;
  std::string source_type;  // e.g. OpenDRIVE "solid broken" + colour; empty for Waymo
  std::vector<glm::dvec3> points;
};

struct Lane {
  int64_t id = 0;
  LaneType type = LaneType::Undefined;
  double speed_limit_mph = 0.0;
  bool interpolating = false;
  std::vector<glm::dvec3> points;  // centre line, in driving direction
  std::vector<int64_t> entry_lanes, exit_lanes, left_neighbors, right_neighbors;
};

// Crosswalks, driveways and speed bumps: closed polygons (last point not repeated).
struct Polygon {
  int64_t id = 0;
  std::vector<glm::dvec3> points;
};

struct StopSign {
  int64_t id = 0;
  glm::dvec3 position{0.0};
  std::vector<int64_t> lanes;
};

struct Map {
  std::vector<RoadEdge> road_edges;
  std::vector<RoadLine> road_lines;
  std::vector<Lane> lanes;
  std::vector<Polygon> crosswalks;
  std::vector<Polygon> driveways;
  std::vector<Polygon> speed_bumps;
  std::vector<StopSign> stop_signs;
  std::string geo_reference;  // OpenDRIVE <geoReference> (PROJ string), verbatim; empty otherwise
};

// ---- objects -------------------------------------------------------------------

enum class ObjectType : int { Unset = 0, Vehicle = 1, Pedestrian = 2, Cyclist = 3, Sign = 4, Other = 5 };

// One oriented 3D box at one timestamp. heading = yaw of the box +x (length)
// axis, CCW from world +x, radians in [-pi, pi). pitch/roll are optional
// (0 when the source has none), applied as Rz(heading)·Ry(pitch)·Rx(roll).
struct BoxState {
  glm::dvec3 center{0.0};
  double length = 0.0, width = 0.0, height = 0.0;
  double heading = 0.0, pitch = 0.0, roll = 0.0;
  glm::dvec2 velocity{0.0};  // m/s, world frame
  bool valid = false;
};

// InfiniCube's static/dynamic split (conventions §5): an object is dynamic if
// its centre ever moves > 0.05 m between consecutive valid 10 Hz states.
inline constexpr double kMovingThresholdMetres = 0.05;
inline constexpr uint32_t kFirstStaticInstanceId = 1;
inline constexpr uint32_t kFirstDynamicInstanceId = 10000;

struct Track {
  int64_t id = 0;  // source id (Waymo track id, or an index)
  ObjectType type = ObjectType::Unset;
  std::vector<BoxState> states;  // one per Scene::timestamps entry
  bool dynamic = false;          // set by classify_tracks()
  uint32_t instance_id = 0;      // 1, 2, ... static; 10000, 10001, ... dynamic; 0 = not assigned
};

// ---- ego and cameras -------------------------------------------------------------

// Pinhole camera (distortion dropped, as InfiniCube does). camera_to_ego is
// the rigid transform from the camera's FLU frame (x forward, y left, z up)
// to the ego frame (FLU), like Waymo's extrinsics; frames.h derives OpenCV
// camera-to-world poses from it.
struct Camera {
  std::string name = "front";
  double fx = 0.0, fy = 0.0, cx = 0.0, cy = 0.0;
  uint32_t width = 0, height = 0;
  glm::dmat4 camera_to_ego{1.0};
};

// Ego pose at one timestamp: ego (FLU) to world.
struct EgoPose {
  glm::dmat4 ego_to_world{1.0};
  bool valid = true;
};

// ---- the scene -------------------------------------------------------------------

struct Provenance {
  std::string source_file;    // path as given to the reader
  std::string source_format;  // "icube-json", "waymo-scenario", "opendrive"
  std::string scenario_id;    // Waymo scenario id, OpenDRIVE header name, ...
  std::string source_version; // e.g. "OpenDRIVE 1.4"
};

struct Scene {
  Provenance provenance;
  std::string prompt;
  std::vector<double> timestamps;  // seconds, increasing; empty when the source has no time (OpenDRIVE)
  Map map;
  std::vector<Track> tracks;
  int sdc_track_index = -1;        // index into tracks of the ego car, -1 when none
  std::vector<EgoPose> ego;        // one per timestamp, or empty
  std::vector<Camera> cameras;
  int current_time_index = 0;
  // What the source could not provide ("ego trajectory", "object boxes",
  // "cameras"): later stages ask for it or synthesise a default.
  std::vector<std::string> missing;
};

// True for the ego car (Scene::sdc_track_index): it is not an object of the scene.
bool is_ego_track(const Scene& scene, size_t track_index);

// Sets Track::dynamic and Track::instance_id as InfiniCube does: static ids
// from 1 and dynamic ids from 10000, each in increasing track-id order. The
// ego track is not an object (InfiniCube's labels never hold the ego): it
// keeps instance_id 0 and dynamic = false.
void classify_tracks(Scene& scene, double moving_threshold = kMovingThresholdMetres);

// True when some non-ego vehicle track has no instance id yet.
bool tracks_unclassified(const Scene& scene);

// The state of track `t` at `time_index` as InfiniCube distributes object
// info over all frames (`distribute_object_info_across_all_frames`,
// data_process/waymo_utils.py: a pass from the last frame to the first, then
// one from the first to the last): the state at `time_index` when valid, else
// the nearest later valid state, else the nearest earlier one; nullptr when
// the track has no valid state or time_index < 0. `source` (optional) receives the index of the
// state returned.
const BoxState* state_filled(const Track& t, int time_index, size_t* source = nullptr);

// InfiniCube's per-frame `object_is_moving` (waymo2webdataset.py): state `i`
// and state i-1 both valid and their centres more than
// kMovingThresholdMetres apart.
bool state_moving(const Track& t, size_t i);

const char* object_type_name(ObjectType t);
const char* road_edge_type_name(RoadEdgeType t);
const char* road_line_type_name(RoadLineType t);
const char* lane_type_name(LaneType t);

}  // namespace icube::scene

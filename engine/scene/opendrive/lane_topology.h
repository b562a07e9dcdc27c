// Lane graph from the OpenDRIVE topology: Lane::exit_lanes / entry_lanes of
// the map's lane centre lines from
//  - lane <link><predecessor|successor id> between consecutive lane sections
//    of a road, and across a road <link> to another road (its contactPoint
//    names the lane section: the first at "start", the last at "end");
//  - junction <connection incomingRoad connectingRoad contactPoint> with its
//    <laneLink from to> (from: lane of the incoming road at its end that
//    meets the junction; to: lane of the connecting road at contactPoint).
// A link only says two lane ends touch; which way it is driven follows from
// the lanes' driving directions (right lanes along +s, left lanes against
// it, flipped on rule="LHT" roads): A -> B when A's driving end and B's
// driving start are the two touching ends. Links whose ends lie more than
// kMaxTopologyGap apart in the sampled geometry, or turn by more than
// kMaxTopologyTurnDeg, are dropped as inconsistent with the geometry.
// Lanes that get no exit here are linked by geometry (layers.h link_lanes).
#pragma once

#include "scene/opendrive/layers.h"
#include "scene/opendrive/xodr_document.h"
#include "scene/scene.h"

#include <vector>

namespace icube::scene::odr {

inline constexpr double kMaxTopologyGap = 1.0;        // metres between A's last and B's first point
inline constexpr double kMaxTopologyTurnDeg = 90.0;  // heading change from A's end to B's start

// Adds the topology's links to map.lanes (spans parallel to map.lanes, from
// emit_lanes; span.road indexes doc.roads).
void link_lanes_by_topology(const Document& doc, const std::vector<LaneSpan>& spans, Map& map);

}  // namespace icube::scene::odr

// Helpers for the OpenDRIVE tests: synthetic .xodr documents and access to
// the real files under $ICUBE_TEST_DATA/maps/opendrive.
#pragma once

#include "gpu_test_context.h"
#include "scene/opendrive_reader.h"

#include <filesystem>
#include <string>

namespace icube::test::odr_util {

// Path of a real map ("carla/Town01.xodr"), empty when the data folder is absent.
inline std::string real_map(const std::string& rel) { return test_data_file("maps/opendrive/" + rel); }

// One right driving lane of `width` and one left driving lane, centre mark solid.
inline std::string two_lane_section(double width = 3.5, const std::string& s = "0") {
  const std::string w = std::to_string(width);
  return "<laneSection s=\"" + s + "\"><left><lane id=\"1\" type=\"driving\" level=\"false\">"
         "<width sOffset=\"0\" a=\"" + w + "\" b=\"0\" c=\"0\" d=\"0\"/></lane></left>"
         "<center><lane id=\"0\" type=\"none\"><roadMark sOffset=\"0\" type=\"solid\" color=\"yellow\"/></lane></center>"
         "<right><lane id=\"-1\" type=\"driving\" level=\"false\">"
         "<width sOffset=\"0\" a=\"" + w + "\" b=\"0\" c=\"0\" d=\"0\"/></lane></right></laneSection>";
}

// A road element; `plan` holds <geometry> elements, `lanes` the <lanes> content.
inline std::string road_xml(const std::string& id, double length, const std::string& plan, const std::string& lanes,
                            const std::string& extra = "", const std::string& attrs = "junction=\"-1\"") {
  return "<road id=\"" + id + "\" length=\"" + std::to_string(length) + "\" " + attrs + ">" + extra + "<planView>" +
         plan + "</planView><lanes>" + lanes + "</lanes></road>\n";
}

inline std::string document(const std::string& body, const std::string& root_attrs = "") {
  return "<?xml version=\"1.0\"?>\n<OpenDRIVE" + root_attrs +
         ">\n<header revMajor=\"1\" revMinor=\"6\" name=\"synthetic\"/>\n" + body + "</OpenDRIVE>\n";
}

inline scene::Scene parse(const std::string& xml, const scene::OpenDriveOptions& o = {},
                          scene::Diagnostics* d = nullptr) {
  return scene::parse_opendrive(xml.data(), xml.size(), "synthetic.xodr", o, d);
}

}  // namespace icube::test::odr_util

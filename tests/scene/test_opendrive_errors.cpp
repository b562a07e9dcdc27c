// OpenDRIVE reader on malformed input: one-line InputErrors naming the file,
// the element and its XML line; warnings for recoverable issues.
#include <doctest/doctest.h>

#include "test_opendrive_util.h"

#include <cmath>
#include <string>

using namespace icube::scene;
using namespace icube::test::odr_util;

namespace {

// The message of the InputError that parsing `xml` with `options` throws ("" when none).
std::string error_of(const std::string& xml, const OpenDriveOptions& options = {}) {
  try {
    parse(xml, options);
  } catch (const InputError& e) {
    CHECK(e.file() == "synthetic.xodr");
    const std::string msg = e.what();
    CHECK(msg.find('\n') == std::string::npos);
    return msg;
  }
  return "";
}

const std::string kGoodGeometry = "<geometry s=\"0\" x=\"0\" y=\"0\" hdg=\"0\" length=\"10\"><line/></geometry>";

std::string one_road(const std::string& plan, const std::string& attrs = "length=\"10\"") {
  // line 1: <?xml?>, 2: <OpenDRIVE>, 3: <header/>, 4: <road>, 5: <planView>, 6: first geometry
  return "<?xml version=\"1.0\"?>\n<OpenDRIVE>\n<header revMajor=\"1\" revMinor=\"4\"/>\n<road id=\"12\" " + attrs +
         " junction=\"-1\">\n<planView>\n" + plan + "\n</planView>\n<lanes>" + two_lane_section() +
         "</lanes></road>\n</OpenDRIVE>\n";
}

}  // namespace

TEST_CASE("OpenDRIVE broken XML is an InputError with the file and line") {
  const std::string msg = error_of("<?xml version=\"1.0\"?>\n<OpenDRIVE>\n<header/>\n<road id=\"1\" length=\"5\">\n</OpenDRIVE>\n");
  CHECK(msg.rfind("synthetic.xodr: line 5: XML parse error", 0) == 0);
  CHECK(error_of("").find("synthetic.xodr: line") == 0);
  CHECK(error_of("<html/>").find("root element is <html>") != std::string::npos);
}

TEST_CASE("OpenDRIVE geometry without length names road, geometry and line") {
  const std::string msg = error_of(one_road(kGoodGeometry + "\n<geometry s=\"10\" x=\"10\" y=\"0\" hdg=\"0\"><line/></geometry>"));
  CHECK(msg == "synthetic.xodr: road 12 geometry 1 (line 7): missing attribute 'length'");
}

TEST_CASE("OpenDRIVE NaN, Inf and garbage numbers are InputErrors") {
  CHECK(error_of(one_road("<geometry s=\"0\" x=\"nan\" y=\"0\" hdg=\"0\" length=\"10\"><line/></geometry>")) ==
        "synthetic.xodr: road 12 geometry 0 (line 6): attribute 'x' is NaN");
  CHECK(error_of(one_road("<geometry s=\"0\" x=\"0\" y=\"-inf\" hdg=\"0\" length=\"10\"><line/></geometry>")) ==
        "synthetic.xodr: road 12 geometry 0 (line 6): attribute 'y' is infinite");
  CHECK(error_of(one_road("<geometry s=\"0\" x=\"0\" y=\"0\" hdg=\"1e999\" length=\"10\"><line/></geometry>"))
            .find("attribute 'hdg' is out of range") != std::string::npos);
  CHECK(error_of(one_road("<geometry s=\"0\" x=\"0\" y=\"0\" hdg=\"0.5rad\" length=\"10\"><line/></geometry>")) ==
        "synthetic.xodr: road 12 geometry 0 (line 6): attribute 'hdg' is not a number: '0.5rad'");
  // underflow is zero, a leading '+' and blanks are fine
  CHECK(error_of(one_road("<geometry s=\" +0 \" x=\"1e-400\" y=\"0\" hdg=\"0\" length=\"10\"><line/></geometry>")).empty());
}

TEST_CASE("OpenDRIVE negative and absurd lengths, bad curvature and missing elements are InputErrors") {
  CHECK(error_of(one_road("<geometry s=\"0\" x=\"0\" y=\"0\" hdg=\"0\" length=\"-1\"><line/></geometry>")) ==
        "synthetic.xodr: road 12 geometry 0 (line 6): negative length -1.000000");
  CHECK(error_of(one_road(kGoodGeometry, "length=\"1e12\"")).find("road 12 (line 4): length") != std::string::npos);
  CHECK(error_of(one_road("<geometry s=\"0\" x=\"0\" y=\"0\" hdg=\"0\" length=\"10\"><arc/></geometry>")) ==
        "synthetic.xodr: road 12 geometry 0 (line 6): missing attribute 'curvature'");
  CHECK(error_of(one_road("<geometry s=\"0\" x=\"0\" y=\"0\" hdg=\"0\" length=\"10\"/>"))
            .find("geometry has no <line>") != std::string::npos);
  CHECK(error_of(one_road("")).find("road has no <planView><geometry>") != std::string::npos);
  CHECK(error_of(one_road(kGoodGeometry, "")).find("missing attribute 'length'") != std::string::npos);
}

TEST_CASE("OpenDRIVE paramPoly3 whose length overflows is an InputError, not a NaN map") {
  const std::string msg = error_of(one_road(
      "<geometry s=\"0\" x=\"0\" y=\"0\" hdg=\"0\" length=\"10\"><paramPoly3 aU=\"0\" bU=\"1\" cU=\"0\" dU=\"1e300\" "
      "aV=\"0\" bV=\"0\" cV=\"0\" dV=\"0\"/></geometry>"));
  CHECK(msg.find("synthetic.xodr: road 12 geometry 0 (line 6)") == 0);
}

TEST_CASE("OpenDRIVE roads more than 1e8 m from the origin are InputErrors naming road and place") {
  // a start point past the bound
  const std::string far = error_of(one_road("<geometry s=\"0\" x=\"2e8\" y=\"0\" hdg=\"0\" length=\"10\"><line/></geometry>"));
  CHECK(far.find("synthetic.xodr: road 12 (line 4): lane border ") == 0);
  CHECK(far.find("reaches (2e+08, ") != std::string::npos);
  CHECK(far.find("more than 1e8 m from the origin") != std::string::npos);
  // finite attributes whose curve leaves the bound: a paramPoly3 offset by 1e71 m across its direction
  const std::string offset = error_of(one_road(
      "<geometry s=\"0\" x=\"0\" y=\"0\" hdg=\"0\" length=\"10\"><paramPoly3 aU=\"0\" bU=\"1\" cU=\"0\" dU=\"0\" "
      "aV=\"1e71\" bV=\"0\" cV=\"0\" dV=\"0\" pRange=\"arcLength\"/></geometry>"));
  CHECK(offset.find("synthetic.xodr: road 12 (line 4): lane border ") == 0);
  CHECK(offset.find("more than 1e8 m from the origin") != std::string::npos);
  // a lane 1e9 m wide
  const std::string wide = error_of(document(road_xml("w", 10, kGoodGeometry, two_lane_section(1e9))));
  CHECK(wide.find("road w (line 4): lane border ") != std::string::npos);
  CHECK(wide.find("more than 1e8 m") != std::string::npos);
  // inside the bound: 9e7 m east and 9e7 m north parse (UTM-sized coordinates are far smaller)
  CHECK(error_of(one_road("<geometry s=\"0\" x=\"9e7\" y=\"-9e7\" hdg=\"0\" length=\"10\"><line/></geometry>")).empty());
}

TEST_CASE("OpenDRIVE lanes on the wrong side, duplicate lanes and huge maps are InputErrors") {
  const std::string wrong = document(road_xml("r", 10, kGoodGeometry,
      "<laneSection s=\"0\"><left><lane id=\"-1\" type=\"driving\"><width sOffset=\"0\" a=\"3\"/></lane></left>"
      "<center><lane id=\"0\"/></center></laneSection>"));
  CHECK(error_of(wrong).find("lane id does not belong in <left>") != std::string::npos);
  const std::string dup = document(road_xml("r", 10, kGoodGeometry,
      "<laneSection s=\"0\"><right><lane id=\"-1\"/><lane id=\"-1\"/></right></laneSection>"));
  CHECK(error_of(dup).find("duplicate lane id") != std::string::npos);
  // 1e6 m of road at 0.25 m is 4e6 samples per border: too many with 5 lanes
  std::string lanes = "<laneSection s=\"0\"><right>";
  for (int i = 1; i <= 5; ++i) lanes += "<lane id=\"-" + std::to_string(i) + "\"><width sOffset=\"0\" a=\"3\"/></lane>";
  lanes += "</right></laneSection>";
  const std::string huge = document(road_xml("r", 1e6, "<geometry s=\"0\" x=\"0\" y=\"0\" hdg=\"0\" length=\"1e6\"><line/></geometry>", lanes));
  CHECK(error_of(huge).find("more than the limit of 2e+07") != std::string::npos);
}

TEST_CASE("OpenDRIVE max_points bounds the samples a map may need; out-of-range bounds are option errors") {
  // 10 m of a two-lane road at 0.25 m: ~43 samples along s on each of 5 borders and centre lines
  const std::string xml = one_road(kGoodGeometry);
  OpenDriveOptions options;
  options.max_points = 100.0;
  const std::string msg = error_of(xml, options);
  CHECK(msg.find("synthetic.xodr: map needs about ") == 0);
  CHECK(msg.find("more than the limit of 100") != std::string::npos);
  options.max_points = 1000.0;
  CHECK_NOTHROW(parse(xml, options));
  for (double bad : {0.0, -1.0, 2e9, std::nan("")}) {
    options.max_points = bad;
    CHECK_THROWS_WITH_AS(parse(xml, options), doctest::Contains("options: max_points must be in [1, 1e9]"), InputError);
  }
}

TEST_CASE("OpenDRIVE recoverable issues are warnings") {
  const std::string plan = "<geometry s=\"5\" x=\"5\" y=\"0\" hdg=\"0\" length=\"5\"><line/></geometry>"
                           "<geometry s=\"0\" x=\"0\" y=\"0\" hdg=\"0\" length=\"5\"><line/></geometry>";
  const std::string xml = "<?xml version=\"1.0\"?><OpenDRIVE>" + road_xml("r", 10.5, plan,
      "<laneSection s=\"0\"><right><lane id=\"-1\" type=\"driving\"/></right></laneSection>") + "</OpenDRIVE>";
  Diagnostics diag;
  const Scene sc = parse(xml, {}, &diag);
  std::string all;
  for (const std::string& w : diag.warnings) all += w + "\n";
  CHECK(all.find("no <header>") != std::string::npos);
  CHECK(all.find("not in s order; sorted") != std::string::npos);
  CHECK(all.find("differs from the plan view's end") != std::string::npos);
  CHECK(all.find("no centre lane") != std::string::npos);
  CHECK(all.find("lane has no <width> or <border>") != std::string::npos);
  CHECK(sc.provenance.source_version == "OpenDRIVE 1.4");
}

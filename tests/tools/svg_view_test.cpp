// SPDX-License-Identifier: Apache-2.0
// mgc-plan --svg: the scenario's working envelope is drawn where the limiter puts it, through the
// views' own world-to-pixel mapping, and a scenario without one draws nothing of it.
#include <catch2/catch.hpp>

#include <cctype>
#include <cmath>
#include <map>
#include <numbers>
#include <string>
#include <vector>

#include "../planning/test_support.hpp"
#include "mgc/planning/io/scenario_loader.hpp"
#include "svg_view.hpp"

using namespace mgc;
using mgc::test::kDeg;

namespace {

using Attributes = std::map<std::string, std::string>;

// Every <tag class="cls" .../> in the document, its attributes by name.
std::vector<Attributes> elements(const std::string& svg, const std::string& tag, const std::string& cls) {
  const std::string open = "<" + tag + " class=\"" + cls + "\"";
  const auto in_name = [](char c) { return std::isalnum(static_cast<unsigned char>(c)) != 0 || c == '_' || c == '-'; };
  std::vector<Attributes> out;
  for (std::size_t at = svg.find(open); at != std::string::npos; at = svg.find(open, at + 1)) {
    const std::string element = svg.substr(at, svg.find('>', at) - at);
    // name="value" pairs read by hand: std::regex here draws GCC 12's -Wmaybe-uninitialized
    // from inside <regex> under the sanitizers.
    Attributes a;
    std::size_t eq = element.find("=\"");
    while (eq != std::string::npos) {
      std::size_t name = eq;
      while (name > 0 && in_name(element[name - 1])) --name;
      const std::size_t close = element.find('"', eq + 2);
      if (close == std::string::npos) break;
      if (name < eq) a[element.substr(name, eq - name)] = element.substr(eq + 2, close - eq - 2);
      eq = element.find("=\"", close + 1);
    }
    out.push_back(a);
  }
  return out;
}

double number(const Attributes& a, const std::string& name) {
  const auto it = a.find(name);
  REQUIRE(it != a.end());
  return std::stod(it->second);
}

// The document prints 6 significant digits: a few hundred pixels to within 1e-3.
Approx px(double value) { return Approx(value).margin(1e-3); }

planning::io::LoadedScenario load(const std::string& name) {
  return planning::io::load_and_build(mgc::test::source_path("scenarios/" + name));
}

tools::SvgInput view_of(const planning::io::LoadedScenario& loaded) {
  tools::SvgInput in;
  in.scenario = &loaded.scenario;
  in.model = loaded.model.get();
  in.step = planning::step_sizes(*loaded.model, loaded.scenario.planner.space_resolution);
  in.path = {loaded.scenario.start, loaded.scenario.goal};
  return in;
}

}  // namespace

TEST_CASE("svg of thesis-steel-frame-road draws wall 0 at x = -8 m in both views and the 40 m ceiling in the side view", "[unit]") {
  const auto loaded = load("thesis-steel-frame-road.yaml");
  const tools::SvgInput in = view_of(loaded);
  const std::string svg = tools::render_svg(in);
  const tools::SvgLayout layout = tools::svg_layout(in);

  // The road: allowed where x >= -8 m, a vertical plane, so a line in both views.
  const auto walls = elements(svg, "line", "envelope wall-0");
  REQUIRE(walls.size() == 2);
  const tools::SvgPanel* panels[] = {&layout.top, &layout.side};
  for (std::size_t v = 0; v < 2; ++v) {
    CAPTURE(v);
    const tools::SvgPanel& panel = *panels[v];
    const double x = panel.map(Eigen::Vector3d(-8.0, 0.0, 0.0))[0];
    CHECK(number(walls[v], "x1") == px(x));
    CHECK(number(walls[v], "x2") == px(x));
    // From edge to edge of its panel, and inside it.
    CHECK(std::abs(number(walls[v], "y1") - number(walls[v], "y2")) == px(panel.height_px));
    CHECK(x > panel.offset_x);
    CHECK(x < panel.offset_x + panel.height_px);
  }
  // The ticks point into the allowed side, +x.
  const auto ticks = elements(svg, "line", "envelope wall-0 tick");
  REQUIRE(ticks.size() == 2);
  for (const Attributes& tick : ticks) CHECK(number(tick, "x2") > number(tick, "x1"));

  // The ceiling in the side view only, at world z = 40 m, across the panel.
  const auto ceiling = elements(svg, "line", "envelope height-ceiling");
  REQUIRE(ceiling.size() == 1);
  const double y = layout.side.map(Eigen::Vector3d(0.0, 0.0, 40.0))[1];
  CHECK(number(ceiling[0], "y1") == px(y));
  CHECK(number(ceiling[0], "y2") == px(y));
  CHECK(number(ceiling[0], "x1") == px(layout.side.offset_x));
  CHECK(number(ceiling[0], "x2") == px(layout.side.offset_x + layout.side.height_px));
  CHECK(y > 0.0);

  CHECK(elements(svg, "circle", "envelope radius-min").empty());
  CHECK(elements(svg, "line", "envelope slew-left").empty());
  CHECK(svg.find("working envelope dashed red-orange, on boom_tip, hook, load_bottom: wall 0 x >= -8 m") != std::string::npos);
  CHECK(svg.find("height ceiling z &lt;= 40 m") != std::string::npos);
}

TEST_CASE("svg draws radius circles and slew rays about the slew axis of a moved and turned base", "[unit]") {
  auto loaded = load("thesis-steel-frame-road.yaml");
  planning::Scenario& scenario = loaded.scenario;
  // The base 5 m east and 3 m south, turned 30 deg: slew limits are azimuths in its frame.
  scenario.world_from_base = Eigen::Isometry3d::Identity();
  scenario.world_from_base.translate(Eigen::Vector3d(5.0, -3.0, 0.0));
  scenario.world_from_base.rotate(Eigen::AngleAxisd(30.0 * kDeg, Eigen::Vector3d::UnitZ()));
  loaded.model = planning::build_model(scenario);
  planning::EnvelopeSpec& e = *scenario.envelope;
  e.radius_min_m = 4.0;
  e.radius_max_m = 30.0;
  e.slew_left_rad = 120.0 * kDeg;
  e.slew_right_rad = -100.0 * kDeg;
  e.depth_floor_m = -2.0;
  e.walls.push_back({Eigen::Vector3d(0.0, 1.0, 1.0).normalized(), -40.0});  // tilted: edge-on in neither view
  const tools::SvgInput in = view_of(loaded);
  const std::string svg = tools::render_svg(in);
  const tools::SvgLayout layout = tools::svg_layout(in);
  const auto axis = layout.top.map(Eigen::Vector3d(5.0, -3.0, 0.0));

  for (const auto& [cls, radius_m] : {std::pair<std::string, double>{"envelope radius-min", 4.0}, {"envelope radius-max", 30.0}}) {
    CAPTURE(cls);
    const auto circle = elements(svg, "circle", cls);
    REQUIRE(circle.size() == 1);
    CHECK(number(circle[0], "cx") == px(axis[0]));
    CHECK(number(circle[0], "cy") == px(axis[1]));
    CHECK(number(circle[0], "r") == px(radius_m * layout.top.scale));
  }
  // Each ray runs from the axis to the maximum radius at world azimuth 30 deg + the limit.
  for (const auto& [cls, azimuth_deg] : {std::pair<std::string, double>{"envelope slew-left", 150.0}, {"envelope slew-right", -70.0}}) {
    CAPTURE(cls);
    const auto ray = elements(svg, "line", cls);
    REQUIRE(ray.size() == 1);
    const Eigen::Vector3d end = Eigen::Vector3d(5.0, -3.0, 0.0) +
                                30.0 * Eigen::Vector3d(std::cos(azimuth_deg * kDeg), std::sin(azimuth_deg * kDeg), 0.0);
    CHECK(number(ray[0], "x1") == px(axis[0]));
    CHECK(number(ray[0], "y1") == px(axis[1]));
    CHECK(number(ray[0], "x2") == px(layout.top.map(end)[0]));
    CHECK(number(ray[0], "y2") == px(layout.top.map(end)[1]));
  }
  const auto floor = elements(svg, "line", "envelope depth-floor");
  REQUIRE(floor.size() == 1);
  CHECK(number(floor[0], "y1") == px(layout.side.map(Eigen::Vector3d(0.0, 0.0, -2.0))[1]));
  // The tilted wall is named in the legend but drawn in neither view; the road still is, twice.
  CHECK(elements(svg, "line", "envelope wall-1").empty());
  CHECK(elements(svg, "line", "envelope wall-0").size() == 2);
  CHECK(svg.find("wall 1 0.7071 y + 0.7071 z >= -40 m") != std::string::npos);
  CHECK(svg.find("slew counter-clockwise from -100 deg to 120 deg") != std::string::npos);
  // Nothing of the envelope is cut off: the circle fits the top view.
  CHECK(axis[0] - 30.0 * layout.top.scale >= layout.top.offset_x);
  CHECK(axis[0] + 30.0 * layout.top.scale <= layout.top.offset_x + layout.top.height_px);
  CHECK(axis[1] - 30.0 * layout.top.scale >= 0.0);
  CHECK(axis[1] + 30.0 * layout.top.scale <= layout.top.height_px);
}

TEST_CASE("svg of a scenario without an envelope section has no envelope element", "[unit]") {
  for (const char* name : {"thesis-steel-frame.yaml", "excavator-pipelines.yaml"}) {
    CAPTURE(name);
    const auto loaded = load(name);
    REQUIRE_FALSE(loaded.scenario.envelope);
    const std::string svg = tools::render_svg(view_of(loaded));
    CHECK(svg.find("envelope") == std::string::npos);
    CHECK(svg.find("height=\"660\"") != std::string::npos);
  }
  // The road scenario with its envelope taken away: no trace of it either.
  auto road = load("thesis-steel-frame-road.yaml");
  road.scenario.envelope.reset();
  CHECK(tools::render_svg(view_of(road)).find("envelope") == std::string::npos);
}

// SPDX-License-Identifier: Apache-2.0
#include "svg_view.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <optional>
#include <sstream>

namespace mgc::tools {
namespace {

using planning::JointVector;
using Point = std::array<double, 2>;
using Polygon = std::vector<Point>;

double cross(const Point& o, const Point& a, const Point& b) {
  return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]);
}

// Andrew's monotone chain: the outline of a body or obstacle seen along one axis.
Polygon convex_hull(Polygon points) {
  std::sort(points.begin(), points.end());
  points.erase(std::unique(points.begin(), points.end()), points.end());
  if (points.size() < 3) return points;
  Polygon hull(2 * points.size());
  std::size_t k = 0;
  for (const Point& p : points) {
    while (k >= 2 && cross(hull[k - 2], hull[k - 1], p) <= 0) --k;
    hull[k++] = p;
  }
  for (std::size_t i = points.size() - 1, t = k + 1; i-- > 0;) {
    while (k >= t && cross(hull[k - 2], hull[k - 1], points[i]) <= 0) --k;
    hull[k++] = points[i];
  }
  hull.resize(k - 1);
  return hull;
}



using Panel = SvgPanel;

std::string polygon(const Panel& panel, const std::vector<Eigen::Vector3d>& points, const char* style) {
  Polygon projected;
  for (const auto& p : points) projected.push_back(panel.map(p));
  std::ostringstream s;
  s << "<polygon points=\"";
  for (const Point& p : convex_hull(projected)) s << p[0] << ',' << p[1] << ' ';
  s << "\" style=\"" << style << "\"/>\n";
  return s.str();
}

std::string polyline(const Panel& panel, const std::vector<Eigen::Vector3d>& points, const char* style) {
  std::ostringstream s;
  s << "<polyline points=\"";
  for (const auto& p : points) {
    const Point q = panel.map(p);
    s << q[0] << ',' << q[1] << ' ';
  }
  s << "\" style=\"fill:none;" << style << "\"/>\n";
  return s.str();
}

// What render_svg draws of the site and the machine, in world coordinates.
struct Scene {
  std::vector<std::vector<Eigen::Vector3d>> obstacles;
  std::vector<std::vector<Eigen::Vector3d>> dynamic;
  std::vector<std::vector<Eigen::Vector3d>> start_bodies;
  std::vector<std::vector<Eigen::Vector3d>> goal_bodies;
  std::vector<Eigen::Vector3d> path_points;
};

// The tool point: the hook for cranes, the bucket tip for the excavator.
int tool_index(const planning::MachineModel& model) {
  return model.key_point_index(model.kind() == planning::MachineKind::Excavator ? "bucket_tip" : "hook");
}

//! The tool point at a configuration, through one reused set of kinematics.
class ToolPoint {
 public:
  explicit ToolPoint(const planning::MachineModel& model) : model_(model), tool_(static_cast<std::size_t>(tool_index(model))) {}
  Eigen::Vector3d operator()(const JointVector& q) {
    model_.forward_kinematics(q, k_);
    return k_.points[tool_];
  }

 private:
  const planning::MachineModel& model_;
  std::size_t tool_;
  planning::Kinematics k_;
};

Scene scene_of(const SvgInput& in) {
  const planning::MachineModel& model = *in.model;
  const planning::Scenario& scenario = *in.scenario;
  ToolPoint tool_point(model);
  planning::Kinematics k;

  Scene scene;
  for (const auto& o : scenario.obstacles) scene.obstacles.push_back(planning::outline_points(o.shape));
  for (std::size_t i = 0; i < scenario.dynamic_obstacles.size(); ++i) {
    const auto& d = scenario.dynamic_obstacles[i];
    const Eigen::Isometry3d pose = i < in.dynamic_poses.size() ? in.dynamic_poses[i] : d.pose_at(0.0);
    for (const auto& part : d.obstacle.parts) scene.dynamic.push_back(planning::outline_points(part, pose));
  }
  const auto machine_at = [&](const JointVector& q) {
    model.forward_kinematics(q, k);
    std::vector<std::vector<Eigen::Vector3d>> bodies;
    for (std::size_t b = 0; b < model.bodies().size(); ++b) {
      bodies.push_back(planning::box_corners(k.bodies[b].world_from_body, k.bodies[b].size_m));
    }
    return bodies;
  };
  scene.start_bodies = machine_at(scenario.start);
  scene.goal_bodies = machine_at(scenario.goal);
  for (std::size_t e = 0; e + 1 < in.path.size(); ++e) {
    const JointVector d = model.difference(in.path[e], in.path[e + 1]);
    int n = 1;
    for (int i = 0; i < model.dof(); ++i) n = std::max(n, static_cast<int>(std::ceil(std::abs(d[i]) / in.step[i])));
    for (int s = (e == 0 ? 0 : 1); s <= n; ++s) {
      scene.path_points.push_back(tool_point(model.interpolate(in.path[e], in.path[e + 1], static_cast<double>(s) / n)));
    }
  }
  return scene;
}

constexpr double kPanelPx = 600.0;
constexpr double kMarginPx = 30.0;

SvgLayout layout_of(const Scene& scene, const SvgInput& in) {
  // One scale for both views, fitted to everything drawn.
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = -lo;
  const auto grow = [&](const std::vector<Eigen::Vector3d>& points) {
    for (const auto& p : points) {
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
  };
  for (const auto& set : {scene.obstacles, scene.dynamic, scene.start_bodies, scene.goal_bodies}) {
    for (const auto& points : set) grow(points);
  }
  grow(scene.path_points);
  if (const auto& envelope = in.scenario->envelope) {
    // The envelope's finite parts stay in view; walls and slew rays run to the panels' edges.
    if (envelope->height_ceiling_m) grow({Eigen::Vector3d(lo.x(), lo.y(), *envelope->height_ceiling_m)});
    if (envelope->depth_floor_m) grow({Eigen::Vector3d(lo.x(), lo.y(), *envelope->depth_floor_m)});
    if (envelope->radius_min_m || envelope->radius_max_m) {
      const double radius_m = std::max(envelope->radius_min_m.value_or(0.0), envelope->radius_max_m.value_or(0.0));
      const Eigen::Vector3d axis = in.model->world_from_base().translation();
      grow({axis - Eigen::Vector3d(radius_m, radius_m, 0.0), axis + Eigen::Vector3d(radius_m, radius_m, 0.0)});
    }
  }
  lo.z() = std::min(lo.z(), 0.0);
  SvgLayout layout;
  layout.span_m = std::max({hi.x() - lo.x(), hi.y() - lo.y(), hi.z() - lo.z(), 1.0});
  const double scale = (kPanelPx - 2 * kMarginPx) / layout.span_m;
  layout.top = Panel{0, 1, lo.x() - kMarginPx / scale, lo.y() - kMarginPx / scale, scale, 0.0, kPanelPx};
  layout.side = Panel{0, 2, lo.x() - kMarginPx / scale, lo.z() - kMarginPx / scale, scale, kPanelPx, kPanelPx};
  return layout;
}

// ---- The working envelope ----

constexpr const char* kEnvelopeStroke = "#ff4500";
constexpr const char* kEnvelopeStyle = "fill:none;stroke:#ff4500;stroke-width:1.5;stroke-dasharray:8,4";

std::string number(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%.4g", std::abs(value) < 5e-10 ? 0.0 : value);
  return text;
}

// The part of the line a + t d, t in [t0, t1], inside the panel (Liang and Barsky's clip). False:
// none of it is.
bool clip(const Panel& panel, const Point& a, const Point& d, double t0, double t1, Point& from, Point& to) {
  const std::array<double, 4> p{-d[0], d[0], -d[1], d[1]};
  const std::array<double, 4> q{a[0] - panel.offset_x, panel.offset_x + panel.height_px - a[0], a[1], panel.height_px - a[1]};
  for (std::size_t i = 0; i < 4; ++i) {
    if (p[i] == 0.0) {
      if (q[i] < 0.0) return false;  // parallel to this edge and outside it
      continue;
    }
    const double t = q[i] / p[i];
    if (p[i] < 0.0) {
      t0 = std::max(t0, t);
    } else {
      t1 = std::min(t1, t);
    }
  }
  if (!(t0 < t1)) return false;
  from = {a[0] + t0 * d[0], a[1] + t0 * d[1]};
  to = {a[0] + t1 * d[0], a[1] + t1 * d[1]};
  return true;
}

std::string line(const std::string& limit, const Point& from, const Point& to, const char* style) {
  std::ostringstream s;
  s << "<line class=\"envelope " << limit << "\" x1=\"" << from[0] << "\" y1=\"" << from[1] << "\" x2=\"" << to[0] << "\" y2=\""
    << to[1] << "\" style=\"" << style << "\"/>\n";
  return s.str();
}

std::string label(const Point& at, const std::string& text, const char* anchor) {
  std::ostringstream s;
  s << "<text class=\"envelope\" x=\"" << at[0] << "\" y=\"" << at[1] << "\" fill=\"" << kEnvelopeStroke
    << "\" font-size=\"12\" text-anchor=\"" << anchor << "\">" << text << "</text>\n";
  return s.str();
}

// The world line through `on` along `along`, clipped to the panel, t in [t0, t1] metres.
bool clip_world(const Panel& panel, const Eigen::Vector3d& on, const Eigen::Vector3d& along, double t0, double t1, Point& from,
                Point& to) {
  const Point a = panel.map(on);
  const Point b = panel.map(on + along);
  return clip(panel, a, {b[0] - a[0], b[1] - a[1]}, t0, t1, from, to);
}

// A wall n . p >= offset is a line in a view that looks along it (n has no component along the
// view's depth axis); seen from any other side it covers the view and is left out. A short tick
// from the line's middle points into the allowed side.
std::string wall(const Panel& panel, int index, const planning::EnvelopeWallSpec& w) {
  const int depth = 3 - panel.axis_x - panel.axis_y;
  constexpr double kEdgeOn = 1e-6;
  if (std::abs(w.normal[depth]) > kEdgeOn) return {};
  Eigen::Vector3d normal = w.normal;
  normal[depth] = 0.0;
  const double norm2 = normal.squaredNorm();
  const Eigen::Vector3d on = normal * (w.offset_m / norm2);
  Eigen::Vector3d along = Eigen::Vector3d::Zero();
  along[panel.axis_x] = -normal[panel.axis_y];
  along[panel.axis_y] = normal[panel.axis_x];
  const double inf = std::numeric_limits<double>::infinity();
  Point from;
  Point to;
  if (!clip_world(panel, on, along, -inf, inf, from, to)) return {};
  const std::string name = "wall-" + std::to_string(index);
  const Point mid{(from[0] + to[0]) / 2, (from[1] + to[1]) / 2};
  const double n = std::sqrt(norm2);
  const Point inward{normal[panel.axis_x] / n, -normal[panel.axis_y] / n};  // the view's y runs down
  constexpr double kTickPx = 10.0;
  std::string out = line(name, from, to, kEnvelopeStyle);
  out += line(name + " tick", mid, {mid[0] + kTickPx * inward[0], mid[1] + kTickPx * inward[1]},
              "stroke:#ff4500;stroke-width:1.5");
  const char* anchor = inward[0] > 0.3 ? "start" : inward[0] < -0.3 ? "end" : "middle";
  out += label({mid[0] + 1.5 * kTickPx * inward[0], mid[1] + 1.5 * kTickPx * inward[1] + 4}, "wall " + std::to_string(index), anchor);
  return out;
}

// Height ceiling or depth floor: a horizontal line in the side view.
std::string level(const Panel& panel, const std::string& limit, double z_m, const std::string& text, double label_dy) {
  const double inf = std::numeric_limits<double>::infinity();
  Point from;
  Point to;
  if (!clip_world(panel, Eigen::Vector3d(0.0, 0.0, z_m), Eigen::Vector3d::UnitX(), -inf, inf, from, to)) return {};
  return line(limit, from, to, kEnvelopeStyle) + label({from[0] + 6, from[1] + label_dy}, text, "start");
}

std::string circle(const Panel& panel, const std::string& limit, const Eigen::Vector3d& axis, double radius_m, const std::string& text) {
  const Point c = panel.map(axis);
  const double r = radius_m * panel.scale;
  std::ostringstream s;
  s << "<circle class=\"envelope " << limit << "\" cx=\"" << c[0] << "\" cy=\"" << c[1] << "\" r=\"" << r << "\" style=\""
    << kEnvelopeStyle << "\"/>\n";
  return s.str() + label({c[0], c[1] - r - 4}, text, "middle");
}

// A slew limit: the ray from the slew axis at the limit's azimuth (base frame, counter-clockwise
// from the base x axis), out to the maximum radius if there is one.
std::string slew_ray(const Panel& panel, const std::string& limit, const Eigen::Isometry3d& world_from_base, double azimuth_rad,
                     std::optional<double> radius_max_m, const std::string& text) {
  const Eigen::Vector3d along = world_from_base.linear() * Eigen::Vector3d(std::cos(azimuth_rad), std::sin(azimuth_rad), 0.0);
  Point from;
  Point to;
  if (!clip_world(panel, world_from_base.translation(), along, 0.0, radius_max_m.value_or(std::numeric_limits<double>::infinity()),
                  from, to)) {
    return {};
  }
  return line(limit, from, to, kEnvelopeStyle) + label(to, text, "middle");
}

std::string degrees(double rad) { return number(rad * 180.0 / std::numbers::pi) + " deg"; }

// The envelope in one view, as guidance::envelope_config reads the spec: walls, ceiling and floor
// in the world frame; radius and slew about the base z axis (vertical: a base has a yaw only).
std::string envelope_view(const Panel& panel, const planning::EnvelopeSpec& e, const Eigen::Isometry3d& world_from_base) {
  std::string out;
  for (std::size_t w = 0; w < e.walls.size(); ++w) out += wall(panel, static_cast<int>(w), e.walls[w]);
  const bool top = panel.axis_y == 1;
  if (top) {
    const Eigen::Vector3d axis = world_from_base.translation();
    if (e.radius_min_m) out += circle(panel, "radius-min", axis, *e.radius_min_m, "radius min " + number(*e.radius_min_m) + " m");
    if (e.radius_max_m) out += circle(panel, "radius-max", axis, *e.radius_max_m, "radius max " + number(*e.radius_max_m) + " m");
    if (e.slew_left_rad && e.slew_right_rad) {
      out += slew_ray(panel, "slew-left", world_from_base, *e.slew_left_rad, e.radius_max_m, "slew left " + degrees(*e.slew_left_rad));
      out += slew_ray(panel, "slew-right", world_from_base, *e.slew_right_rad, e.radius_max_m, "slew right " + degrees(*e.slew_right_rad));
    }
  } else {
    // The ceiling's label above its line, the floor's below.
    if (e.height_ceiling_m) {
      out += level(panel, "height-ceiling", *e.height_ceiling_m, "height ceiling " + number(*e.height_ceiling_m) + " m", -5);
    }
    if (e.depth_floor_m) out += level(panel, "depth-floor", *e.depth_floor_m, "depth floor " + number(*e.depth_floor_m) + " m", 15);
  }
  return out;
}

// "x >= -8 m", "0.7071 x + 0.7071 y >= 3 m": where a wall allows.
std::string wall_text(const planning::EnvelopeWallSpec& w) {
  std::string text;
  for (int i = 0; i < 3; ++i) {
    const double c = w.normal[i];
    if (std::abs(c) < 1e-9) continue;
    const char axis = static_cast<char>('x' + i);
    if (!text.empty()) text += c < 0 ? " - " : " + ";
    const double shown = text.empty() ? c : std::abs(c);
    text += (shown == 1.0 ? "" : shown == -1.0 ? "-" : number(shown) + " ") + std::string(1, axis);
  }
  return text + " >= " + number(w.offset_m) + " m";
}

// The legend's lines: what the envelope limits, broken to fit the document's width.
std::vector<std::string> envelope_legend(const planning::EnvelopeSpec& e) {
  std::string points;
  for (std::size_t i = 0; i < e.points.size(); ++i) points += (i ? ", " : "") + e.points[i];
  std::vector<std::string> parts;
  for (std::size_t w = 0; w < e.walls.size(); ++w) parts.push_back("wall " + std::to_string(w) + " " + wall_text(e.walls[w]));
  if (e.height_ceiling_m) parts.push_back("height ceiling z &lt;= " + number(*e.height_ceiling_m) + " m");
  if (e.depth_floor_m) parts.push_back("depth floor z >= " + number(*e.depth_floor_m) + " m");
  if (e.radius_min_m) parts.push_back("radius >= " + number(*e.radius_min_m) + " m");
  if (e.radius_max_m) parts.push_back("radius &lt;= " + number(*e.radius_max_m) + " m");
  if (e.slew_left_rad && e.slew_right_rad) {
    parts.push_back("slew counter-clockwise from " + degrees(*e.slew_right_rad) + " to " + degrees(*e.slew_left_rad));
  }
  if (!e.walls.empty()) parts[e.walls.size() - 1] += " (ticks point into the allowed side)";
  constexpr std::size_t kLineChars = 150;  // about the document's width at 14 px
  std::vector<std::string> lines{"working envelope dashed red-orange, on " + points + ":"};
  for (const std::string& part : parts) {
    if (lines.back().size() + part.size() + 2 > kLineChars) {
      lines.back() += ",";
      lines.push_back(part);
    } else {
      lines.back() += (lines.back().back() == ':' ? " " : ", ") + part;
    }
  }
  return lines;
}

}  // namespace

SvgLayout svg_layout(const SvgInput& in) { return layout_of(scene_of(in), in); }

std::string render_svg(const SvgInput& in) {
  const planning::MachineModel& model = *in.model;
  const planning::Scenario& scenario = *in.scenario;
  ToolPoint tool_point(model);
  const Scene scene = scene_of(in);
  const SvgLayout layout = layout_of(scene, in);
  const double span = layout.span_m;
  const Panel& top = layout.top;
  const Panel& side = layout.side;
  const std::vector<std::string> legend = scenario.envelope ? envelope_legend(*scenario.envelope) : std::vector<std::string>{};
  const double height_px = kPanelPx + 60 + 25 * static_cast<double>(legend.size());

  std::ostringstream svg;
  svg << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << 2 * kPanelPx << "\" height=\"" << height_px
      << "\" font-family=\"sans-serif\" font-size=\"14\">\n";
  svg << "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";
  for (const Panel* panel : {&top, &side}) {
    for (const auto& o : scene.obstacles) svg << polygon(*panel, o, "fill:#bbbbbb;fill-opacity:0.5;stroke:#777777;stroke-width:0.5");
    for (const auto& o : scene.dynamic) svg << polygon(*panel, o, "fill:#e07b39;fill-opacity:0.4;stroke:#b35000;stroke-dasharray:4,3");
    for (const auto& b : scene.start_bodies) svg << polygon(*panel, b, "fill:#3b6fd4;fill-opacity:0.35;stroke:#1d3f8a");
    for (const auto& b : scene.goal_bodies) svg << polygon(*panel, b, "fill:#2e9e4f;fill-opacity:0.35;stroke:#17612d");
    if (!in.tree_nodes.empty()) {
      for (std::size_t i = 0; i < in.tree_nodes.size(); ++i) {
        if (in.tree_parents[i] < 0) continue;
        svg << polyline(*panel, {tool_point(in.tree_nodes[static_cast<std::size_t>(in.tree_parents[i])]), tool_point(in.tree_nodes[i])},
                        "stroke:#999999;stroke-width:0.7");
      }
    }
    if (!scene.path_points.empty()) svg << polyline(*panel, scene.path_points, "stroke:#c0392b;stroke-width:2");
    if (scenario.envelope) svg << envelope_view(*panel, *scenario.envelope, model.world_from_base());
  }
  svg << "<line x1=\"" << kPanelPx << "\" y1=\"0\" x2=\"" << kPanelPx << "\" y2=\"" << kPanelPx << "\" stroke=\"black\"/>\n";
  svg << "<text x=\"10\" y=\"" << kPanelPx + 20 << "\">top view (x, y)</text>\n";
  svg << "<text x=\"" << kPanelPx + 10 << "\" y=\"" << kPanelPx + 20 << "\">side view (x, z), "
      << static_cast<int>(std::lround(span)) << " m across</text>\n";
  svg << "<text x=\"10\" y=\"" << kPanelPx + 45 << "\">" << scenario.name
      << ": obstacles grey, moving obstacles orange (" << (in.dynamic_poses.empty() ? "at t = 0" : in.dynamic_poses_label)
      << "), machine at start blue and at goal green, "
      << (model.kind() == planning::MachineKind::Excavator ? "bucket-tip" : "hook") << " path red"
      << (in.tree_nodes.empty() ? "" : ", tree grey lines") << "</text>\n";
  for (std::size_t i = 0; i < legend.size(); ++i) {
    svg << "<text x=\"10\" y=\"" << kPanelPx + 70 + 25 * static_cast<double>(i) << "\" fill=\"" << kEnvelopeStroke << "\">" << legend[i]
        << "</text>\n";
  }
  svg << "</svg>\n";
  return svg.str();
}

}  // namespace mgc::tools

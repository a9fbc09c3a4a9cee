// SPDX-License-Identifier: Apache-2.0
#include "svg_view.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
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

// The 8 corners of a box of `size` (full extents) placed by `pose`.
std::vector<Eigen::Vector3d> box_corners(const Eigen::Isometry3d& pose, const Eigen::Vector3d& size) {
  std::vector<Eigen::Vector3d> corners;
  for (int c = 0; c < 8; ++c) {
    const Eigen::Vector3d unit((c & 1) ? 0.5 : -0.5, (c & 2) ? 0.5 : -0.5, (c & 4) ? 0.5 : -0.5);
    corners.push_back(pose * unit.cwiseProduct(size));
  }
  return corners;
}

std::vector<Eigen::Vector3d> shape_corners(const planning::ShapePart& shape, const Eigen::Isometry3d& owner) {
  if (shape.kind == planning::ShapeKind::Mesh) {
    std::vector<Eigen::Vector3d> out;
    for (const auto& v : shape.vertices_m) out.push_back(owner * shape.pose * v);
    return out;
  }
  Eigen::Vector3d size = shape.size_m;
  if (shape.kind == planning::ShapeKind::Capsule) size.z() += size.x();  // the hemispherical ends
  return box_corners(owner * shape.pose, size);
}

struct Panel {
  int axis_x = 0;
  int axis_y = 1;
  double min_x = 0, min_y = 0, scale = 1, offset_x = 0;
  double height_px = 0;
  Point map(const Eigen::Vector3d& p) const {
    return {offset_x + (p[axis_x] - min_x) * scale, height_px - (p[axis_y] - min_y) * scale};
  }
};

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

}  // namespace

std::string render_svg(const SvgInput& in) {
  const planning::MachineModel& model = *in.model;
  const planning::Scenario& scenario = *in.scenario;
  // The tool point: the hook for cranes, the bucket tip for the excavator.
  const int tool = model.key_point_index(model.kind() == planning::MachineKind::Excavator ? "bucket_tip" : "hook");
  planning::Kinematics k;
  const auto tool_point = [&](const JointVector& q) {
    model.forward_kinematics(q, k);
    return k.points[static_cast<std::size_t>(tool)];
  };

  std::vector<std::vector<Eigen::Vector3d>> obstacles;
  for (const auto& o : scenario.obstacles) obstacles.push_back(shape_corners(o.shape, Eigen::Isometry3d::Identity()));
  std::vector<std::vector<Eigen::Vector3d>> dynamic;
  for (std::size_t i = 0; i < scenario.dynamic_obstacles.size(); ++i) {
    const auto& d = scenario.dynamic_obstacles[i];
    const Eigen::Isometry3d pose = i < in.dynamic_poses.size() ? in.dynamic_poses[i] : d.pose_at(0.0);
    for (const auto& part : d.obstacle.parts) dynamic.push_back(shape_corners(part, pose));
  }
  const auto machine_at = [&](const JointVector& q) {
    model.forward_kinematics(q, k);
    std::vector<std::vector<Eigen::Vector3d>> bodies;
    for (std::size_t b = 0; b < model.bodies().size(); ++b) {
      bodies.push_back(box_corners(k.bodies[b].world_from_body, k.bodies[b].size_m));
    }
    return bodies;
  };
  const auto start_bodies = machine_at(scenario.start);
  const auto goal_bodies = machine_at(scenario.goal);
  std::vector<Eigen::Vector3d> path_points;
  for (std::size_t e = 0; e + 1 < in.path.size(); ++e) {
    const JointVector d = model.difference(in.path[e], in.path[e + 1]);
    int n = 1;
    for (int i = 0; i < model.dof(); ++i) n = std::max(n, static_cast<int>(std::ceil(std::abs(d[i]) / in.step[i])));
    for (int s = (e == 0 ? 0 : 1); s <= n; ++s) {
      path_points.push_back(tool_point(model.interpolate(in.path[e], in.path[e + 1], static_cast<double>(s) / n)));
    }
  }

  // One scale for both views, fitted to everything drawn.
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = -lo;
  const auto grow = [&](const std::vector<Eigen::Vector3d>& points) {
    for (const auto& p : points) {
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
  };
  for (const auto& set : {obstacles, dynamic, start_bodies, goal_bodies}) {
    for (const auto& points : set) grow(points);
  }
  grow(path_points);
  lo.z() = std::min(lo.z(), 0.0);
  constexpr double kPanelPx = 600.0;
  constexpr double kMarginPx = 30.0;
  const double span = std::max({hi.x() - lo.x(), hi.y() - lo.y(), hi.z() - lo.z(), 1.0});
  const double scale = (kPanelPx - 2 * kMarginPx) / span;
  Panel top{0, 1, lo.x() - kMarginPx / scale, lo.y() - kMarginPx / scale, scale, 0.0, kPanelPx};
  Panel side{0, 2, lo.x() - kMarginPx / scale, lo.z() - kMarginPx / scale, scale, kPanelPx, kPanelPx};

  std::ostringstream svg;
  svg << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << 2 * kPanelPx << "\" height=\"" << kPanelPx + 60
      << "\" font-family=\"sans-serif\" font-size=\"14\">\n";
  svg << "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";
  for (const Panel* panel : {&top, &side}) {
    for (const auto& o : obstacles) svg << polygon(*panel, o, "fill:#bbbbbb;fill-opacity:0.5;stroke:#777777;stroke-width:0.5");
    for (const auto& o : dynamic) svg << polygon(*panel, o, "fill:#e07b39;fill-opacity:0.4;stroke:#b35000;stroke-dasharray:4,3");
    for (const auto& b : start_bodies) svg << polygon(*panel, b, "fill:#3b6fd4;fill-opacity:0.35;stroke:#1d3f8a");
    for (const auto& b : goal_bodies) svg << polygon(*panel, b, "fill:#2e9e4f;fill-opacity:0.35;stroke:#17612d");
    if (!in.tree_nodes.empty()) {
      for (std::size_t i = 0; i < in.tree_nodes.size(); ++i) {
        if (in.tree_parents[i] < 0) continue;
        svg << polyline(*panel, {tool_point(in.tree_nodes[static_cast<std::size_t>(in.tree_parents[i])]), tool_point(in.tree_nodes[i])},
                        "stroke:#999999;stroke-width:0.7");
      }
    }
    if (!path_points.empty()) svg << polyline(*panel, path_points, "stroke:#c0392b;stroke-width:2");
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
  svg << "</svg>\n";
  return svg.str();
}

}  // namespace mgc::tools

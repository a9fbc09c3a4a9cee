// SPDX-License-Identifier: Apache-2.0
#include "mgc/planning/io/scenario_loader.hpp"
#include "mgc/planning/machine_tags.hpp"

#include <cmath>
#include <map>
#include <new>
#include <numbers>
#include <set>
#include <sstream>
#include <system_error>

#include "dual_crane_fields.hpp"
#include "geometry_fields.hpp"
#include "scenario_fields.hpp"
#include "work_cycle_fields.hpp"
#include "yaml_fields.hpp"

namespace mgc::planning::io {
namespace {

constexpr double kDegToRad = std::numbers::pi / 180.0;

std::string format_number(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

// ---------------------------------------------------------------------------------------------
// Machine files

const std::vector<std::pair<const char*, JointType>>& expected_joints(MachineKind kind) {
  static const std::vector<std::pair<const char*, JointType>> mobile = {
      {"swing", JointType::Revolute},
      {"boom_elevation", JointType::Revolute},
      {"boom_length", JointType::Prismatic},
      {"cable_length", JointType::Prismatic}};
  static const std::vector<std::pair<const char*, JointType>> tower = {
      {"slew", JointType::Revolute}, {"trolley_radius", JointType::Prismatic}, {"hook_height", JointType::Prismatic}};
  static const std::vector<std::pair<const char*, JointType>> excavator = {
      {"swing", JointType::Revolute}, {"boom", JointType::Revolute}, {"arm", JointType::Revolute},
      {"bucket", JointType::Revolute}};
  switch (kind) {
    case MachineKind::MobileCrane: return mobile;
    case MachineKind::TowerCrane: return tower;
    case MachineKind::Excavator: return excavator;
  }
  return mobile;
}

JointSpec read_joint(const Value& value, const std::pair<const char*, JointType>& expected) {
  Fields f = value.fields();
  JointSpec j;
  const Value name = f.required("name");
  j.name = name.text();
  if (j.name != expected.first) name.fail(std::string("joint '") + expected.first + "' here (joints are in a fixed order)");
  const Value type = f.required("type");
  j.type = type.choice({"revolute", "prismatic"}) == "revolute" ? JointType::Revolute : JointType::Prismatic;
  if (j.type != expected.second) type.fail(expected.second == JointType::Revolute ? "revolute" : "prismatic");
  const bool revolute = j.type == JointType::Revolute;
  // Angles are in degrees in files, lengths in metres; field names carry the unit.
  const double scale = revolute ? kDegToRad : 1.0;
  const std::string u = revolute ? "deg" : "m";
  if (revolute) {
    if (auto c = f.optional("continuous")) j.continuous = c->boolean();
  }
  const Value range = f.required("range_" + u);
  const auto [lo, hi] = range.increasing_pair();
  for (const Value& end : range.list()) (void)(revolute ? end.angle_deg() : end.coordinate_m());
  if (j.continuous && std::abs((hi - lo) - 360.0) > 1e-9) range.fail("a full turn [min, min + 360] for a continuous joint");
  if (revolute && !j.continuous && hi - lo > 360.0) range.fail("a range of at most 360 deg");
  j.position_min = lo * scale;
  j.position_max = hi * scale;
  j.max_velocity = f.required("max_velocity_" + u + "_s").positive() * scale;
  j.max_acceleration = f.required("max_acceleration_" + u + "_s2").positive() * scale;
  j.max_jerk = f.required("max_jerk_" + u + "_s3").positive() * scale;
  f.finish();
  return j;
}

// A cell of a chart: a number, or null where the published chart has no entry.
std::vector<std::vector<double>> read_grid(const Value& value, std::size_t rows, std::size_t columns, double lo,
                                           double hi, const char* what) {
  const auto row_values = value.non_empty_list();
  if (row_values.size() != rows) value.fail("a list of " + std::to_string(rows) + " rows (one per boom length)");
  std::vector<std::vector<double>> grid;
  for (const Value& row : row_values) {
    const auto cells = row.list();
    if (cells.size() != columns) row.fail("a row of " + std::to_string(columns) + " cells (one per radius)");
    std::vector<double> out;
    for (const Value& cell : cells) {
      if (cell.is_null()) {
        out.push_back(std::numeric_limits<double>::quiet_NaN());
        continue;
      }
      const double v = cell.number();
      if (v < lo || v > hi) cell.fail(std::string(what) + " in [" + format_number(lo) + ", " + format_number(hi) + "] or null");
      out.push_back(v);
    }
    grid.push_back(std::move(out));
  }
  return grid;
}

LoadChart read_load_chart(const Value& value) {
  Fields f = value.fields();
  LoadChart c;
  c.rating = f.required("rating").text();
  c.outriggers = f.required("outriggers").text();
  c.counterweight_lb = f.required("counterweight_lb").non_negative();
  c.boom_lengths_ft = f.required("boom_lengths_ft").numbers(true);
  c.radii_ft = f.required("radii_ft").numbers(true);
  const Value capacity = f.required("capacity_lb");
  c.capacity_lb = read_grid(capacity, c.boom_lengths_ft.size(), c.radii_ft.size(), 1e-9, 1e7, "a capacity");
  const Value angles = f.required("max_angle_from_vertical_deg");
  c.max_angle_from_vertical_deg = read_grid(angles, c.boom_lengths_ft.size(), c.radii_ft.size(), 0.0, 90.0, "an angle");
  for (std::size_t r = 0; r < c.capacity_lb.size(); ++r) {
    for (std::size_t k = 0; k < c.radii_ft.size(); ++k) {
      if (!std::isnan(c.capacity_lb[r][k]) && std::isnan(c.max_angle_from_vertical_deg[r][k])) {
        angles.list()[r].list()[k].fail("an angle where the capacity table has a capacity");
      }
    }
  }
  f.finish();
  return c;
}

LuffRangeTable read_luff_table(const Value& value) {
  Fields f = value.fields();
  LuffRangeTable t;
  const Value lengths = f.required("boom_lengths_ft");
  t.boom_lengths_ft = lengths.numbers(true);
  const Value mins = f.required("luff_min_deg");
  const Value maxs = f.required("luff_max_deg");
  t.luff_min_deg = mins.numbers(false);
  t.luff_max_deg = maxs.numbers(false);
  if (t.luff_min_deg.size() != t.boom_lengths_ft.size()) mins.fail(std::to_string(t.boom_lengths_ft.size()) + " values (one per boom length)");
  if (t.luff_max_deg.size() != t.boom_lengths_ft.size()) maxs.fail(std::to_string(t.boom_lengths_ft.size()) + " values (one per boom length)");
  const auto max_items = maxs.list();
  for (std::size_t i = 0; i < t.luff_min_deg.size(); ++i) {
    if (!(t.luff_min_deg[i] < t.luff_max_deg[i])) max_items[i].fail("a maximum above the row's minimum " + format_number(t.luff_min_deg[i]));
  }
  f.finish();
  return t;
}

// Every failure leaves the loader as InputError naming the file, whatever threw it, so that
// programs that catch InputError never abort on an exception they did not expect.
template <class Read>
auto guarded(const std::string& file, Read&& read) {
  try {
    return read();
  } catch (const InputError&) {
    throw;
  } catch (const std::bad_alloc&) {
    throw InputError(file, 0, "", "out of memory while reading the file");
  } catch (const std::exception& e) {
    throw InputError(file, 0, "", std::string("cannot read the file: ") + e.what());
  }
}

MachineDefinition read_machine(const std::filesystem::path& path) {
  const std::string file = path.string();
  const YAML::Node root = load_yaml(file);
  const Value root_value(root, "", &file, 1);
  Fields f = root_value.fields();
  MachineDefinition m;
  m.file = file;
  const Value kind = f.required("kind");
  const std::string k = kind.choice({"mobile_crane", "tower_crane", "excavator"});
  m.kind = k == "mobile_crane" ? MachineKind::MobileCrane : k == "tower_crane" ? MachineKind::TowerCrane : MachineKind::Excavator;
  m.name = f.required("name").name();
  m.source = f.required("source").text();

  const Value joints = f.required("joints");
  const auto items = joints.non_empty_list();
  const auto& expected = expected_joints(m.kind);
  if (items.size() != expected.size()) {
    std::string names;
    for (const auto& e : expected) names += (names.empty() ? "" : ", ") + std::string(e.first);
    joints.fail(std::to_string(expected.size()) + " joints (" + names + ")");
  }
  for (std::size_t i = 0; i < items.size(); ++i) m.joints.push_back(read_joint(items[i], expected[i]));

  const Value geometry = f.required("geometry");
  switch (m.kind) {
    case MachineKind::MobileCrane: read_geometry(geometry, m.mobile_crane); break;
    case MachineKind::TowerCrane: read_geometry(geometry, m.tower_crane); break;
    case MachineKind::Excavator: read_geometry(geometry, m.excavator); break;
  }
  if (m.kind == MachineKind::MobileCrane) {
    if (auto chart = f.optional("load_chart")) m.load_chart = read_load_chart(*chart);
    if (auto table = f.optional("luff_range_table")) m.luff_table = read_luff_table(*table);
  }
  f.finish();
  return m;
}

Eigen::Matrix3d rotation_from_rpy_deg(const Eigen::Vector3d& rpy_deg) {
  return (Eigen::AngleAxisd(rpy_deg.z() * kDegToRad, Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(rpy_deg.y() * kDegToRad, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(rpy_deg.x() * kDegToRad, Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

Eigen::Vector3d read_rpy_deg(const Value& value) {
  Eigen::Vector3d rpy_deg = value.vec3();
  const auto items = value.list();
  for (int i = 0; i < 3; ++i) rpy_deg[i] = items[static_cast<std::size_t>(i)].angle_deg();
  return rpy_deg;
}

void read_pose(Fields& f, Eigen::Isometry3d& pose) {
  pose = Eigen::Isometry3d::Identity();
  pose.translation() = f.required("position_m").position_m();
  if (auto rpy = f.optional("rpy_deg")) pose.linear() = rotation_from_rpy_deg(read_rpy_deg(*rpy));
}

// The shape fields of one obstacle or obstacle part; `f` has its type already read.
ShapePart read_shape(Fields& f, const Value& type_value, const std::string& type) {
  ShapePart s;
  if (type == "box") {
    s.kind = ShapeKind::Box;
    s.size_m = f.required("size_m").size_m();
  } else if (type == "cylinder" || type == "capsule") {
    s.kind = type == "cylinder" ? ShapeKind::Cylinder : ShapeKind::Capsule;
    const double r = f.required("radius_m").length_m();
    const double l = f.required("length_m").length_m();
    s.size_m = Eigen::Vector3d(2.0 * r, 2.0 * r, l);
  } else if (type == "mesh") {
    s.kind = ShapeKind::Mesh;
    for (const Value& v : f.required("vertices_m").non_empty_list()) s.vertices_m.push_back(v.position_m());
    const int n = static_cast<int>(s.vertices_m.size());
    for (const Value& t : f.required("triangles").non_empty_list()) {
      const auto idx = t.list();
      if (idx.size() != 3) t.fail("a triangle [i, j, k] of vertex indices");
      Eigen::Vector3i tri;
      for (int i = 0; i < 3; ++i) tri[i] = idx[static_cast<std::size_t>(i)].integer(0, n - 1);
      if (tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2]) t.fail("three different vertex indices");
      s.triangles.push_back(tri);
    }
  } else {
    type_value.fail("one of box, cylinder, capsule, mesh");
  }
  read_pose(f, s.pose);
  return s;
}

// A steel frame of columns and beams on a rectangular grid, expanded into boxes named
// "<name>/column[i,j,k]", "<name>/beam-x[i,j,k]" and "<name>/beam-y[i,j,k]".
void read_steel_frame(Fields& f, const std::string& name, std::vector<StaticObstacle>& out) {
  const Eigen::Vector3d origin = f.required("origin_m").position_m();
  const double yaw = f.optional("yaw_deg") ? f.optional("yaw_deg")->angle_deg() * kDegToRad : 0.0;
  const Value bays_value = f.required("bays");
  const auto bays = bays_value.list();
  if (bays.size() != 2) bays_value.fail("[bays along x, bays along y]");
  const int nx = bays[0].integer(1, 100);
  const int ny = bays[1].integer(1, 100);
  const Value bay_size_value = f.required("bay_size_m");
  const auto bay = bay_size_value.list();
  if (bay.size() != 2) bay_size_value.fail("[bay length along x, along y]");
  const double bx = bay[0].length_m();
  const double by = bay[1].length_m();
  const Value storey_value = f.required("storeys");
  const int storeys = storey_value.integer(1, 100);
  const double h = f.required("storey_height_m").length_m();
  const Value column_value = f.required("column_section_m");
  const auto column = column_value.list();
  if (column.size() != 2) column_value.fail("[width, depth] of the column section");
  const double cw = column[0].length_m();
  const double cd = column[1].length_m();
  const Value beam_value = f.required("beam_section_m");
  const auto beam = beam_value.list();
  if (beam.size() != 2) beam_value.fail("[width, height] of the beam section");
  const double bw = beam[0].length_m();
  const double bh = beam[1].length_m();
  // The frame's own lengths are lengths on the site too.
  if (!(nx * bx <= kSiteExtent_m && ny * by <= kSiteExtent_m)) {
    bay_size_value.fail_plain("the frame is " + format_number(nx * bx) + " m by " + format_number(ny * by) +
                              " m (bays x bay size); expected at most " + format_number(kSiteExtent_m) + " m (the site extent)");
  }
  if (!(storeys * h <= kSiteExtent_m)) {
    storey_value.fail_plain("the frame is " + format_number(storeys * h) + " m tall (storeys x storey height); expected at most " +
                            format_number(kSiteExtent_m) + " m (the site extent)");
  }
  const std::size_t members = static_cast<std::size_t>(storeys) *
                              static_cast<std::size_t>((nx + 1) * (ny + 1) + nx * (ny + 1) + (nx + 1) * ny);
  if (out.size() + members > kMaxStaticObstacles) {
    bays_value.fail_plain("the frame has " + std::to_string(members) + " members, which with the " + std::to_string(out.size()) +
                          " static obstacles before it exceeds the limit of " + std::to_string(kMaxStaticObstacles));
  }

  // A frame adds up to kMaxStaticObstacles boxes at once; growing the list one box at a time would
  // copy the boxes before it again at every doubling.
  out.reserve(out.size() + members);

  Eigen::Isometry3d frame = Eigen::Isometry3d::Identity();
  frame.translate(origin);
  frame.rotate(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()));
  const auto add = [&](const std::string& member, int i, int j, int k, const Eigen::Vector3d& centre,
                       const Eigen::Vector3d& size) {
    StaticObstacle o;
    o.name = name + "/" + member + "[" + std::to_string(i) + "," + std::to_string(j) + "," + std::to_string(k) + "]";
    o.shape.kind = ShapeKind::Box;
    o.shape.size_m = size;
    o.shape.pose = frame * Eigen::Translation3d(centre);
    out.push_back(std::move(o));
  };
  for (int k = 0; k < storeys; ++k) {
    const double z_top = (k + 1) * h;
    for (int i = 0; i <= nx; ++i) {
      for (int j = 0; j <= ny; ++j) {
        add("column", i, j, k, {i * bx, j * by, z_top - 0.5 * h}, {cw, cd, h});
      }
    }
    for (int i = 0; i < nx; ++i) {
      for (int j = 0; j <= ny; ++j) add("beam-x", i, j, k, {(i + 0.5) * bx, j * by, z_top - 0.5 * bh}, {bx, bw, bh});
    }
    for (int i = 0; i <= nx; ++i) {
      for (int j = 0; j < ny; ++j) add("beam-y", i, j, k, {i * bx, (j + 0.5) * by, z_top - 0.5 * bh}, {bw, by, bh});
    }
  }
}

void read_obstacles(const Value& value, std::vector<StaticObstacle>& out, std::set<std::string>& names) {
  for (const Value& item : value.list()) {
    if (out.size() >= kMaxStaticObstacles) item.fail_plain("more than " + std::to_string(kMaxStaticObstacles) + " static obstacles, the limit");
    Fields f = item.fields();
    const Value name_value = f.required("name");
    const std::string name = name_value.name();
    if (!names.insert(name).second) name_value.fail("a name not used by another obstacle");
    const Value type = f.required("type");
    const std::string t = type.choice({"box", "cylinder", "capsule", "mesh", "steel_frame"});
    if (t == "steel_frame") {
      read_steel_frame(f, name, out);
    } else {
      StaticObstacle o;
      o.name = name;
      o.shape = read_shape(f, type, t);
      out.push_back(std::move(o));
    }
    f.finish();
  }
}

DynamicObstacleSpec read_dynamic(const Value& value, std::set<std::string>& names, std::set<int>& tag_ids) {
  Fields f = value.fields();
  DynamicObstacleSpec d;
  const Value name_value = f.required("name");
  d.obstacle.name = name_value.name();
  if (!names.insert(d.obstacle.name).second) name_value.fail("a name not used by another obstacle");
  for (const Value& part : f.required("parts").non_empty_list()) {
    Fields pf = part.fields();
    const Value type = pf.required("type");
    const std::string t = type.choice({"box", "cylinder", "capsule", "mesh"});
    d.obstacle.parts.push_back(read_shape(pf, type, t));
    pf.finish();
  }
  for (const Value& key : f.required("motion").non_empty_list()) {
    Fields kf = key.fields();
    Keyframe k;
    const Value t = kf.required("t_s");
    k.t_s = t.number_in(0.0, kMaxScriptTime_s);
    if (!d.motion.empty() && !(k.t_s > d.motion.back().t_s)) t.fail("a time after the previous key's " + format_number(d.motion.back().t_s) + " s");
    k.position_m = kf.required("position_m").position_m();
    k.yaw_rad = kf.required("yaw_deg").angle_deg() * kDegToRad;
    kf.finish();
    d.motion.push_back(k);
  }
  if (auto tags = f.optional("tags")) {
    for (const Value& tag : tags->list()) {
      Fields tf = tag.fields();
      UwbTagSpec t;
      const Value id = tf.required("id");
      t.id = id.integer(0, 255);
      if (!tag_ids.insert(t.id).second) id.fail("a tag id not used by another tag");
      t.position_m = tf.required("position_m").position_m();
      tf.finish();
      d.tags.push_back(t);
    }
  }
  f.finish();
  return d;
}

// machine_tags: UWB tags on the machine itself, on the bodies and frames machine_tags.hpp accepts.
std::vector<MachineTagSpec> read_machine_tags(const Value& value, const Scenario& s, std::set<int>& tag_ids) {
  std::vector<MachineTagSpec> tags;
  for (const Value& tag : value.list()) {
    if (tags.size() == kMaxMachineTags) tag.fail_plain("at most " + std::to_string(kMaxMachineTags) + " machine tags");
    Fields tf = tag.fields();
    MachineTagSpec t;
    const Value id = tf.required("id");
    t.id = id.integer(0, 255);
    if (!tag_ids.insert(t.id).second) id.fail("a tag id not used by another tag (obstacle tags included)");
    const Value body = tf.required("body");
    t.body = body.name();
    if (const std::string problem = tag_mount_problem(s.machine.kind, s.dual_crane.has_value(), t.body); !problem.empty()) {
      body.fail(problem);
    }
    t.ref = {body.file(), body.line(), body.path()};
    const Value position = tf.required("position_m");
    t.position_m = position.position_m();
    if (!(t.position_m.norm() <= kMaxMachineTagOffset_m)) {
      position.fail("a position within " + format_number(kMaxMachineTagOffset_m) + " m of the body's origin");
    }
    tf.finish();
    tags.push_back(std::move(t));
  }
  return tags;
}

// simulation: mgc-sim's settings for this site; ranges as docs/simulator.md states them.
SimulationSpec read_simulation(const Value& value) {
  Fields f = value.fields();
  SimulationSpec sim;
  const auto number_in = [&f](const char* key, double lo, double hi, std::optional<double>& out) {
    if (auto v = f.optional(key)) out = v->number_in(lo, hi);
  };
  number_in("physics_rate_hz", 100.0, 10'000.0, sim.physics_rate_hz);
  number_in("actuator_lag_s", 0.0, 5.0, sim.actuator_lag_s);
  number_in("valve_deadband_pct", 0.0, 50.0, sim.valve_deadband_pct);
  number_in("encoder_noise_counts", 0.0, 1000.0, sim.encoder_noise_counts);
  number_in("uwb_noise_sigma_m", 0.0, 10.0, sim.uwb_noise_sigma_m);
  number_in("uwb_rate_hz", 0.1, 100.0, sim.uwb_rate_hz);
  number_in("uwb_latency_ms", 0.0, 5000.0, sim.uwb_latency_ms);
  number_in("uwb_dropout_pct", 0.0, 100.0, sim.uwb_dropout_pct);
  number_in("scenario_time_offset_s", 0.0, 1e6, sim.scenario_time_offset_s);
  if (auto faults = f.optional("faults")) {
    for (const Value& fault : faults->list()) sim.faults.emplace_back(fault.text(), SourceRef{fault.file(), fault.line(), fault.path()});
  }
  f.finish();
  return sim;
}

// envelope: working-envelope limits on named key points (docs/scenario-format.md). The names are
// resolved against the machine model by its user (guidance::envelope_config), which names this
// section's line when one is unknown.
EnvelopeSpec read_envelope(const Value& value) {
  constexpr std::size_t kMaxWalls = 8;  // guidance::EnvelopeConfig::kMaxWalls
  Fields f = value.fields();
  EnvelopeSpec e;
  const Value points = f.required("points");
  std::set<std::string> seen;
  for (const Value& p : points.non_empty_list()) {
    std::string name = p.name();
    if (!seen.insert(name).second) p.fail("a key point not already listed");
    e.points.push_back(std::move(name));
  }
  e.points_ref = {value.file(), points.line(), points.path()};
  if (auto v = f.optional("height_ceiling_m")) e.height_ceiling_m = v->coordinate_m();
  if (auto v = f.optional("depth_floor_m")) {
    e.depth_floor_m = v->coordinate_m();
    if (e.height_ceiling_m && !(*e.depth_floor_m < *e.height_ceiling_m)) v->fail("a floor below height_ceiling_m");
  }
  auto left = f.optional("slew_left_deg");
  auto right = f.optional("slew_right_deg");
  if (left.has_value() != right.has_value()) {
    (left ? *left : *right).fail_plain("slew limits come in pairs: give slew_left_deg and slew_right_deg");
  }
  if (left) {
    e.slew_left_rad = left->number_in(-180.0, 180.0) * kDegToRad;
    e.slew_right_rad = right->number_in(-180.0, 180.0) * kDegToRad;
    if (*e.slew_left_rad == *e.slew_right_rad) left->fail("an angle other than slew_right_deg (the allowed sector runs counter-clockwise from right to left)");
  }
  if (auto v = f.optional("radius_min_m")) e.radius_min_m = v->non_negative_length_m();
  if (auto v = f.optional("radius_max_m")) {
    e.radius_max_m = v->length_m();
    if (e.radius_min_m && !(*e.radius_max_m > *e.radius_min_m)) v->fail("a radius above radius_min_m");
  }
  if (auto walls = f.optional("walls")) {
    const std::vector<Value> list = walls->non_empty_list();
    if (list.size() > kMaxWalls) walls->fail("at most " + std::to_string(kMaxWalls) + " walls");
    for (const Value& w : list) {
      Fields wf = w.fields();
      const Value normal = wf.required("normal");
      EnvelopeWallSpec wall;
      wall.normal = normal.vec3();
      // stableNorm: components near the largest double would overflow the plain norm to infinity.
      const double norm = wall.normal.stableNorm();
      if (!(norm > 1e-9)) normal.fail("a non-zero normal pointing into the allowed side");
      wall.normal /= norm;
      wall.offset_m = wf.required("offset_m").coordinate_m();
      wf.finish();
      e.walls.push_back(wall);
    }
  }
  if (auto v = f.optional("slowdown_band_m")) e.slowdown_band_m = v->length_m();
  f.finish();
  if (!e.height_ceiling_m && !e.depth_floor_m && !e.slew_left_rad && !e.radius_min_m && !e.radius_max_m && e.walls.empty()) {
    value.fail_plain("an envelope needs at least one limit (height_ceiling_m, depth_floor_m, slew_left_deg/slew_right_deg, "
                     "radius_min_m, radius_max_m or walls)");
  }
  return e;
}

// guidance: the controller's clearance margins (docs/scenario-format.md). Each is a positive length;
// how they must relate (stop < warning, stop <= escape <= planning) the controller checks with the
// defaults of the fields not given, naming this section's line.
GuidanceSpec read_guidance(const Value& value) {
  Fields f = value.fields();
  GuidanceSpec g;
  g.ref = {value.file(), value.line(), value.path()};
  const auto margin = [&f](const char* key, std::optional<double>& out) {
    if (auto v = f.optional(key)) out = v->number_in(0.01, 10.0);
  };
  margin("stop_margin_m", g.stop_margin_m);
  margin("warning_margin_m", g.warning_margin_m);
  margin("planning_margin_m", g.planning_margin_m);
  margin("escape_margin_m", g.escape_margin_m);
  f.finish();
  return g;
}

// start/goal: one field per joint, named after the joint with its unit: swing_deg, boom_length_m.
JointVector read_configuration(const Value& value, const MachineDefinition& machine) {
  Fields f = value.fields();
  JointVector q(static_cast<int>(machine.joints.size()));
  for (std::size_t i = 0; i < machine.joints.size(); ++i) {
    const JointSpec& j = machine.joints[i];
    const bool revolute = j.type == JointType::Revolute;
    const std::string key = j.name + (revolute ? "_deg" : "_m");
    const Value v = f.required(key);
    const double scale = revolute ? kDegToRad : 1.0;
    const double x = revolute ? v.angle_deg() : v.coordinate_m();
    if (!j.continuous && (x * scale < j.position_min - 1e-12 || x * scale > j.position_max + 1e-12)) {
      v.fail("a value within the joint range [" + format_number(j.position_min / scale) + ", " +
             format_number(j.position_max / scale) + "] " + (revolute ? "deg" : "m") + " of " + machine.file);
    }
    q[static_cast<int>(i)] = j.continuous ? wrap_angle(x * scale) : x * scale;
  }
  f.finish();
  return q;
}

TaskSpec read_task(const Value& value, const MachineDefinition& machine) {
  Fields f = value.fields();
  TaskSpec t;
  if (machine.kind == MachineKind::MobileCrane) {
    auto [key, load] = f.one_of({"load_lb", "load_kg"});
    t.load_lb = key == "load_lb" ? load.positive() : load.positive() / kKilogramsPerPound;
    t.load_ref = {load.file(), load.line(), load.path()};
    if (auto r = f.optional("capacity_reduction_pct")) t.capacity_reduction_pct = r->number_in(0.0, 100.0);
    const Value constraint = f.required("constraint");
    const std::string c = constraint.choice({"load_chart", "luff_table", "none"});
    t.constraint = c == "load_chart" ? CraneConstraintMode::LoadChart
                   : c == "luff_table" ? CraneConstraintMode::LuffTable
                                       : CraneConstraintMode::None;
    const Value outriggers = f.required("outriggers");
    t.outriggers = outriggers.text();
    const Value counterweight = f.required("counterweight_lb");
    t.counterweight_lb = counterweight.non_negative();
    if (t.constraint == CraneConstraintMode::LuffTable && !machine.luff_table) {
      constraint.fail("a constraint the machine file defines (" + machine.file + " has no luff_range_table)");
    }
    if (t.constraint == CraneConstraintMode::LoadChart) {
      if (!machine.load_chart) constraint.fail("a constraint the machine file defines (" + machine.file + " has no load_chart)");
      const LoadChart& chart = *machine.load_chart;
      if (t.outriggers != chart.outriggers) {
        outriggers.fail("'" + chart.outriggers + "', the rigging of the load chart in " + machine.file);
      }
      if (t.counterweight_lb != chart.counterweight_lb) {
        counterweight.fail(format_number(chart.counterweight_lb) + ", the counterweight of the load chart in " + machine.file);
      }
      const double rated_load = t.load_lb * (100.0 + t.capacity_reduction_pct) / 100.0;
      double max_capacity = 0.0;
      for (const auto& row : chart.capacity_lb) {
        for (double cap : row) {
          if (!std::isnan(cap)) max_capacity = std::max(max_capacity, cap);
        }
      }
      if (rated_load > max_capacity) {
        load.fail("a load the chart rates (at most " + format_number(max_capacity) + " lb incl. capacity reduction; this is " +
                  format_number(rated_load) + " lb)");
      }
    }
  }
  t.load_size_m = f.required("load_size_m").size_m();
  t.sling_length_m = f.required("sling_length_m").non_negative_length_m();
  f.finish();
  return t;
}

PlannerParams read_planner(const Value& value) {
  Fields f = value.fields();
  PlannerParams p;
  if (auto v = f.optional("seed")) p.seed = v->unsigned_integer();
  if (auto v = f.optional("max_iterations")) p.max_iterations = v->integer(1, 100000000);
  if (auto v = f.optional("goal_bias")) p.goal_bias = v->number_in(0.0, 1.0);
  if (auto v = f.optional("space_resolution")) p.space_resolution = v->integer(1, 1000000);
  if (auto v = f.optional("error_tolerance")) p.error_tolerance = v->positive();
  if (auto v = f.optional("dilation_m")) p.dilation_m = v->non_negative_length_m();
  if (auto v = f.optional("replan_max_iterations")) p.replan_max_iterations = v->integer(1, 100000000);
  if (auto v = f.optional("replan_goal_bias")) p.replan_goal_bias = v->number_in(0.0, 1.0);
  f.finish();
  return p;
}

}  // namespace

MachineDefinition read_machine_field(const Value& machine_value, const std::filesystem::path& folder, const char* owner) {
  const std::string machine_name = machine_value.text();
  // A NUL would silently cut the path the system sees; no file name needs a control character.
  for (const char c : machine_name) {
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) machine_value.fail("a path without control characters");
  }
  const std::filesystem::path machine_path = folder / machine_name;
  // Looked at before load_machine, so that the complaint names this field; the error_code forms
  // throw nothing, not even for a name longer than the system allows.
  std::error_code missing;
  if (!std::filesystem::exists(machine_path, missing) && !missing) {
    machine_value.fail("a machine file relative to the " + std::string(owner) + "'s folder (" +
                       echo(machine_path.string(), kMaxPathEchoChars) + " does not exist)");
  }
  if (const std::string problem = input_file_problem(machine_path); !problem.empty()) {
    machine_value.fail_plain("the machine file " + echo(machine_path.string(), kMaxPathEchoChars) + ": " + problem);
  }
  return load_machine(machine_path);
}

void read_static_obstacles(const Value& value, std::vector<StaticObstacle>& out) {
  std::set<std::string> names;
  read_obstacles(value, out, names);
}

JointVector read_configuration_field(const Value& value, const MachineDefinition& machine) {
  return read_configuration(value, machine);
}

TaskSpec read_task_field(const Value& value, const MachineDefinition& machine) { return read_task(value, machine); }

PlannerParams read_planner_field(const Value& value) { return read_planner(value); }

namespace {

Scenario read_scenario(const std::filesystem::path& path) {
  const std::string file = path.string();
  const YAML::Node root = load_yaml(file);
  const Value root_value(root, "", &file, 1);
  Fields f = root_value.fields();
  Scenario s;
  s.file = file;
  s.name = f.required("name").name();
  if (auto d = f.optional("description")) s.description = d->text();

  s.machine = read_machine_field(f.required("machine"), path.parent_path(), "scenario");
  if (auto dual = f.optional("dual_crane")) s.dual_crane = read_dual_crane(*dual, s.machine);

  if (s.dual_crane) {
    if (auto base = f.optional("base")) base->fail_plain("a dual-crane scenario places its cranes in dual_crane.crane_1 and crane_2");
  } else {
    Fields base = f.required("base").fields();
    s.world_from_base = Eigen::Isometry3d::Identity();
    s.world_from_base.translate(base.required("position_m").position_m());
    s.world_from_base.rotate(Eigen::AngleAxisd(base.required("yaw_deg").angle_deg() * kDegToRad, Eigen::Vector3d::UnitZ()));
    base.finish();
  }

  if (s.machine.kind == MachineKind::Excavator) {
    if (auto task = f.optional("task")) task->fail_plain("an excavator scenario has no task (no load is lifted)");
  } else if (s.dual_crane) {
    if (auto task = f.optional("task")) task->fail_plain("a dual-crane scenario has no task: the load is dual_crane.girder");
  } else {
    s.task = read_task(f.required("task"), s.machine);
  }

  std::set<std::string> names;
  read_obstacles(f.required("obstacles"), s.obstacles, names);
  std::set<int> tag_ids;
  if (auto dynamic = f.optional("dynamic_obstacles")) {
    for (const Value& d : dynamic->list()) s.dynamic_obstacles.push_back(read_dynamic(d, names, tag_ids));
  }
  if (auto tags = f.optional("machine_tags")) s.machine_tags = read_machine_tags(*tags, s, tag_ids);

  const Value start = f.required("start");
  s.start = read_configuration(start, s.machine);
  s.start_ref = {file, start.line(), "start"};
  const Value goal = f.required("goal");
  s.goal = read_configuration(goal, s.machine);
  s.goal_ref = {file, goal.line(), "goal"};
  if (auto cycle = f.optional("work_cycle")) {
    s.work_cycle = read_work_cycle(*cycle, s, goal, [&](const Value& v) { return read_configuration(v, s.machine); });
  }
  s.planner = read_planner(f.required("planner"));
  if (auto envelope = f.optional("envelope")) s.envelope = read_envelope(*envelope);
  if (auto guidance = f.optional("guidance")) s.guidance = read_guidance(*guidance);
  if (auto sim = f.optional("simulation")) s.simulation = read_simulation(*sim);
  f.finish();
  return s;
}

LoadedScenario build_scenario(const std::filesystem::path& file) {
  LoadedScenario out;
  out.scenario = load_scenario(file);
  try {
    out.model = build_model(out.scenario);
  } catch (const std::invalid_argument& e) {
    const SourceRef& ref = out.scenario.task ? out.scenario.task->load_ref : out.scenario.start_ref;
    throw InputError(ref.file, ref.line, ref.field, e.what());
  }
  try {
    out.world = build_world(out.scenario, *out.model);
  } catch (const std::invalid_argument& e) {
    throw InputError(out.scenario.file, 0, "obstacles", e.what());
  }
  return out;
}

}  // namespace

MachineDefinition load_machine(const std::filesystem::path& path) {
  return guarded(path.string(), [&] { return read_machine(path); });
}

Scenario load_scenario(const std::filesystem::path& path) {
  return guarded(path.string(), [&] { return read_scenario(path); });
}

LoadedScenario load_and_build(const std::filesystem::path& path) {
  return guarded(path.string(), [&] { return build_scenario(path); });
}

std::vector<InputError> check_endpoints(LoadedScenario& loaded) {
  std::vector<InputError> errors;
  const auto check = [&](const JointVector& q, const SourceRef& ref) {
    const Validity v = loaded.world->validate(q);
    if (v.valid()) return;
    std::string message = "infeasible: " + loaded.world->describe(v);
    if (v.status == Validity::Status::Constraint && v.constraint.chart_row >= 0 && loaded.scenario.machine.load_chart) {
      const LoadChart& chart = *loaded.scenario.machine.load_chart;
      message += " (load-chart row " + format_number(chart.boom_lengths_ft[static_cast<std::size_t>(v.constraint.chart_row)]) + " ft boom";
      if (v.constraint.chart_column >= 0) {
        message += ", radius " + format_number(chart.radii_ft[static_cast<std::size_t>(v.constraint.chart_column)]) + " ft";
      }
      message += ")";
    }
    if (v.status == Validity::Status::Constraint && v.constraint.status != ConstraintStatus::LoadAboveChart) {
      const ConstraintStatus c = v.constraint.status;
      const bool angle = c == ConstraintStatus::BoomBelowChartAngle || c == ConstraintStatus::BoomAboveChartAngle ||
                         c == ConstraintStatus::NoEquilibrium || c == ConstraintStatus::CableTilt ||
                         c == ConstraintStatus::GirderTilt;
      const double scale = angle ? 180.0 / std::numbers::pi : 1.0;
      const char* unit = angle ? " deg" : c == ConstraintStatus::CraneOverload ? " lb" : " m";
      message += ": value " + format_number(v.constraint.value * scale) + unit + ", limit " +
                 format_number(v.constraint.limit * scale) + unit;
    }
    errors.emplace_back(ref.file, ref.line, ref.field, message);
  };
  check(loaded.scenario.start, loaded.scenario.start_ref);
  check(loaded.scenario.goal, loaded.scenario.goal_ref);
  if (const auto& cycle = loaded.scenario.work_cycle) {
    check(cycle->dumped, cycle->dumped_ref);
    if (!cycle->next_dig_ref.field.empty()) check(cycle->next_dig, cycle->next_dig_ref);
  }
  return errors;
}

}  // namespace mgc::planning::io

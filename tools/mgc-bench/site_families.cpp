// SPDX-License-Identifier: Apache-2.0
#include "site_families.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <system_error>

#include "mgc/planning/collision_world.hpp"
#include "mgc/planning/io/input_error.hpp"
#include "mgc/planning/io/scenario_loader.hpp"
#include "mgc/planning/load_chart.hpp"
#include "mgc/planning/machine_model.hpp"

#include "site_draw.hpp"

namespace mgc::bench {

namespace {

using planning::Validity;

constexpr double kDeg = std::numbers::pi / 180.0;

// Grove TMS870 (machines/grove-tms870.yaml): boom pin 3 m above the ground on the swing axis,
// boom 36-110 ft, elevation 0-80 deg, cable 1-36 m.
constexpr double kCraneFootM = 3.0;
constexpr double kCraneBoomMinM = 10.9728;
constexpr double kCraneBoomMaxM = 33.528;
constexpr double kCraneCableMinM = 1.0;
constexpr double kCraneCableMaxM = 36.0;
constexpr double kCraneElevationMaxDeg = 80.0;

// Pecco SK 180 (machines/pecco-sk180.yaml): trolley 3-59.7 m, hook 0-45 m above the base.
constexpr double kTowerTrolleyMinM = 3.0;
constexpr double kTowerTrolleyMaxM = 59.7;
constexpr double kTowerHookMaxM = 45.0;

// Cat 320 (machines/cat-320.yaml): planar chain from the boom foot 0.25 m forward, 2 m up.
constexpr double kExcFootForwardM = 0.25;
constexpr double kExcFootHeightM = 2.0;
constexpr double kExcBoomM = 5.7;
constexpr double kExcArmM = 2.9;
constexpr double kExcBucketM = 1.47;
constexpr std::array<double, 2> kExcBoomRangeDeg = {-50.0, 60.0};
constexpr std::array<double, 2> kExcArmRangeDeg = {-155.0, -30.0};
constexpr std::array<double, 2> kExcBucketRangeDeg = {-170.0, 10.0};

using SiteRng = site_draw::SplitMix64;
using site_draw::num;
using site_draw::wrap_deg;
using site_draw::write_text;

std::uint64_t family_hash(const std::string& name) {
  std::uint64_t h = 0xCBF29CE484222325ULL;  // FNV-1a
  for (const char c : name) {
    h ^= static_cast<unsigned char>(c);
    h *= 0x100000001B3ULL;
  }
  return h;
}


std::string vec(double x, double y, double z) { return "[" + num(x) + ", " + num(y) + ", " + num(z) + "]"; }


//! The parts of a scenario file a family draws; the rest is common.
struct Draft {
  std::string comment;    //!< what this site is, one or two lines
  std::string task;       //!< the `task:` section's lines, cranes only
  std::string obstacles;  //!< list items
  std::string start, goal;
  std::string dynamic;    //!< the `dynamic_obstacles:` list items, if any
};

void box(Draft& d, const std::string& name, std::array<double, 3> size, std::array<double, 3> centre,
         std::array<double, 3> rpy = {0.0, 0.0, 0.0}) {
  d.obstacles += "  - name: " + name + "\n    type: box\n    size_m: " + vec(size[0], size[1], size[2]) +
                 "\n    position_m: " + vec(centre[0], centre[1], centre[2]) + "\n";
  if (rpy != std::array<double, 3>{0.0, 0.0, 0.0}) d.obstacles += "    rpy_deg: " + vec(rpy[0], rpy[1], rpy[2]) + "\n";
}

//! A box standing on the ground, turned by yaw_deg about its vertical axis.
void block(Draft& d, const std::string& name, double cx, double cy, double sx, double sy, double height, double yaw_deg = 0.0) {
  box(d, name, {sx, sy, height}, {cx, cy, 0.5 * height}, {0.0, 0.0, yaw_deg});
}

void round_shape(Draft& d, const std::string& type, const std::string& name, double radius, double length,
                 std::array<double, 3> centre, std::array<double, 3> rpy = {0.0, 0.0, 0.0}) {
  d.obstacles += "  - name: " + name + "\n    type: " + type + "\n    radius_m: " + num(radius) + "\n    length_m: " + num(length) +
                 "\n    position_m: " + vec(centre[0], centre[1], centre[2]) + "\n";
  if (rpy != std::array<double, 3>{0.0, 0.0, 0.0}) d.obstacles += "    rpy_deg: " + vec(rpy[0], rpy[1], rpy[2]) + "\n";
}

void steel_frame(Draft& d, const std::string& name, double ox, double oy, double yaw_deg, int nx, int ny, int storeys) {
  d.obstacles += "  - name: " + name + "\n    type: steel_frame\n    origin_m: " + vec(ox, oy, 0.0) + "\n    yaw_deg: " + num(yaw_deg) +
                 "\n    bays: [" + std::to_string(nx) + ", " + std::to_string(ny) + "]\n    bay_size_m: [6, 6]\n    storeys: " +
                 std::to_string(storeys) +
                 "\n    storey_height_m: 4\n    column_section_m: [0.4, 0.4]\n    beam_section_m: [0.3, 0.6]\n";
}

// ---- Mobile crane -------------------------------------------------------------------------------

//! The lift: load, box hung under the hook and sling.
struct CraneLoad {
  double lb = 0.0;
  double sx = 0.0, sy = 0.0, sz = 0.0;
  double sling_m = 0.0;
};

CraneLoad crane_load(SiteRng& rng, double lb_lo, double lb_hi) {
  CraneLoad l;
  l.lb = 500.0 * std::round(rng.uniform(lb_lo, lb_hi) / 500.0);
  l.sx = rng.uniform(2.0, 4.0);
  l.sy = rng.uniform(1.5, 2.5);
  l.sz = rng.uniform(0.8, 1.5);
  l.sling_m = rng.uniform(1.5, 3.0);
  return l;
}

std::string crane_task(const CraneLoad& l) {
  return "  load_lb: " + num(l.lb) +
         "\n  capacity_reduction_pct: 0\n  outriggers: fully_extended\n  counterweight_lb: 18000\n  constraint: load_chart\n"
         "  load_size_m: " + vec(l.sx, l.sy, l.sz) + "\n  sling_length_m: " + num(l.sling_m) + "\n";
}

std::string crane_joints(double swing_deg, double elevation_deg, double boom_m, double cable_m) {
  return "  swing_deg: " + num(wrap_deg(swing_deg)) + "\n  boom_elevation_deg: " + num(elevation_deg) +
         "\n  boom_length_m: " + num(boom_m) + "\n  cable_length_m: " + num(cable_m) + "\n";
}

//! The crane pose that hangs the load's centre at horizontal radius r_m, azimuth swing_deg, with
//! its bottom bottom_m above the ground, on a boom boom_m long; nothing when out of reach.
std::optional<std::string> crane_pose(const CraneLoad& l, double swing_deg, double r_m, double bottom_m, double boom_m) {
  boom_m = std::clamp(boom_m, kCraneBoomMinM, kCraneBoomMaxM);
  if (r_m >= boom_m - 0.05) return std::nullopt;
  const double elevation_deg = std::acos(r_m / boom_m) / kDeg;
  const double cable_m = kCraneFootM + boom_m * std::sin(elevation_deg * kDeg) - bottom_m - l.sz - l.sling_m;
  if (elevation_deg > kCraneElevationMaxDeg || cable_m < kCraneCableMinM || cable_m > kCraneCableMaxM) return std::nullopt;
  return crane_joints(swing_deg, elevation_deg, boom_m, cable_m);
}

//! A low pick or set-down at radius r_m: a boom between r_m + 2 m and r_m + 10 m.
std::optional<std::string> crane_low_pose(SiteRng& rng, const CraneLoad& l, double swing_deg, double r_m) {
  return crane_pose(l, swing_deg, r_m, rng.uniform(0.3, 1.0), rng.uniform(r_m + 2.0, r_m + 10.0));
}

bool set_endpoints(Draft& d, const std::optional<std::string>& start, const std::optional<std::string>& goal) {
  if (!start || !goal) return false;
  d.start = *start;
  d.goal = *goal;
  return true;
}

//! Context a family may need besides the random numbers.
struct DrawContext {
  const planning::LoadChart* crane_chart = nullptr;
};

bool crane_l_frame(SiteRng& rng, const DrawContext&, Draft& d) {
  const CraneLoad l = crane_load(rng, 5000, 9000);
  const double x0 = rng.uniform(9.0, 12.0), y0 = rng.uniform(-10.0, -4.0);
  const int storeys = rng.integer(2, 3), along_y = rng.integer(3, 4), along_x = rng.integer(2, 3);
  steel_frame(d, "frame-a", x0, y0, 0.0, 1, along_y, storeys);
  steel_frame(d, "frame-b", x0 + 6.0, y0, 0.0, along_x, 1, storeys);
  const double gx = x0 + 6.0 + rng.uniform(2.5, 8.0), gy = y0 + 6.0 + rng.uniform(2.5, 8.0);
  const double start_swing = rng.sign() * rng.uniform(100.0, 160.0);
  d.comment = "an L of steel frame east of the crane; the goal low in the L's inner corner, behind the frame";
  d.task = crane_task(l);
  return set_endpoints(d, crane_low_pose(rng, l, start_swing, rng.uniform(11.0, 16.0)),
                       crane_pose(l, std::atan2(gy, gx) / kDeg, std::hypot(gx, gy), rng.uniform(0.3, 1.0),
                                  rng.uniform(std::hypot(gx, gy) + 1.5, kCraneBoomMaxM)));
}

bool crane_rotated_frame(SiteRng& rng, const DrawContext&, Draft& d) {
  const CraneLoad l = crane_load(rng, 6000, 12000);
  const int nx = rng.integer(3, 5), ny = rng.integer(2, 3), storeys = rng.integer(2, 4);
  const double yaw = rng.sign() * rng.uniform(15.0, 75.0);
  const double cx = rng.uniform(20.0, 26.0), cy = rng.uniform(-4.0, 4.0);
  const double c = std::cos(yaw * kDeg), s = std::sin(yaw * kDeg);
  const double hx = 3.0 * nx, hy = 3.0 * ny;  // half the grid
  steel_frame(d, "frame", cx - (c * hx - s * hy), cy - (s * hx + c * hy), yaw, nx, ny, storeys);
  d.comment = "a steel frame turned off the carrier's axis; pick north, set down south, both low";
  d.task = crane_task(l);
  return set_endpoints(d, crane_low_pose(rng, l, rng.uniform(60.0, 110.0), rng.uniform(11.0, 17.0)),
                       crane_low_pose(rng, l, -rng.uniform(60.0, 110.0), rng.uniform(11.0, 17.0)));
}

bool crane_tower_gap(SiteRng& rng, const DrawContext&, Draft& d) {
  const CraneLoad l = crane_load(rng, 3000, 5000);
  const double xc = rng.uniform(16.0, 20.0), w = rng.uniform(6.0, 9.0);
  const double dy1 = rng.uniform(8.0, 12.0), dy2 = rng.uniform(8.0, 12.0);
  const double gap = 5.0, shift = rng.uniform(-1.0, 1.0);
  block(d, "tower-north", xc, shift + 0.5 * gap + 0.5 * dy1, w, dy1, 40.0);
  block(d, "tower-south", xc, shift - 0.5 * gap - 0.5 * dy2, w, dy2, 40.0);
  const double gx = xc + 0.5 * w + rng.uniform(3.0, 5.0), gy = shift + rng.uniform(-1.0, 1.0);
  const double r = std::hypot(gx, gy);
  d.comment = "two 40 m towers with a 5 m gap between them; the goal low behind the gap";
  d.task = crane_task(l);
  return set_endpoints(d, crane_low_pose(rng, l, rng.sign() * rng.uniform(70.0, 120.0), rng.uniform(12.0, 18.0)),
                       crane_pose(l, std::atan2(gy, gx) / kDeg, r, rng.uniform(0.3, 1.0), rng.uniform(r + 1.0, kCraneBoomMaxM)));
}

bool crane_roof_telescope(SiteRng& rng, const DrawContext&, Draft& d) {
  const CraneLoad l = crane_load(rng, 3000, 5000);
  const double bx = rng.uniform(9.0, 12.0), depth = rng.uniform(12.0, 18.0), width = rng.uniform(16.0, 24.0);
  const double height = rng.uniform(12.0, 20.0);
  block(d, "building", bx + 0.5 * depth, 0.0, depth, width, height);
  const double start_boom = rng.uniform(11.0, 12.0);
  const double gx = rng.uniform(bx + 3.0, bx + depth - 3.0), gy = rng.uniform(-0.5 * width + 3.0, 0.5 * width - 3.0);
  d.comment = "a building east of the crane; from a short boom (~11 m) low on the far side onto its roof on a ~30 m boom";
  d.task = crane_task(l);
  return set_endpoints(d, crane_pose(l, rng.sign() * rng.uniform(100.0, 180.0), rng.uniform(8.0, start_boom - 1.5),
                                     rng.uniform(0.3, 1.0), start_boom),
                       crane_pose(l, std::atan2(gy, gx) / kDeg, std::hypot(gx, gy), height + rng.uniform(0.3, 0.8),
                                  rng.uniform(29.0, 31.0)));
}

bool crane_long_swing(SiteRng& rng, const DrawContext&, Draft& d) {
  const CraneLoad l = crane_load(rng, 6000, 12000);
  const double swing = rng.uniform(-180.0, 180.0);
  const double delta = (rng.next() & 1U) != 0U ? 175.0 : 180.0;
  const double side = rng.sign();
  const double at = (swing + side * 90.0) * kDeg, rho = rng.uniform(14.0, 20.0);
  block(d, "building", rho * std::cos(at), rho * std::sin(at), rng.uniform(8.0, 12.0), rng.uniform(8.0, 12.0),
        rng.uniform(15.0, 30.0), wrap_deg(at / kDeg));
  d.comment = "a swing of " + num(delta) + " deg with a building on one side of it";
  d.task = crane_task(l);
  return set_endpoints(d, crane_low_pose(rng, l, swing, rng.uniform(11.0, 16.0)),
                       crane_low_pose(rng, l, swing + delta, rng.uniform(11.0, 16.0)));
}

bool crane_tilted_boxes(SiteRng& rng, const DrawContext&, Draft& d) {
  const CraneLoad l = crane_load(rng, 6000, 12000);
  const int n = rng.integer(4, 7);
  for (int i = 0; i < n; ++i) {
    const double at = rng.uniform(-180.0, 180.0) * kDeg, rho = rng.uniform(9.0, 26.0);
    const double sz = rng.uniform(3.0, 12.0);
    box(d, "box-" + std::to_string(i + 1), {rng.uniform(3.0, 8.0), rng.uniform(3.0, 8.0), sz},
        {rho * std::cos(at), rho * std::sin(at), 0.5 * sz},
        {rng.uniform(-20.0, 20.0), rng.uniform(-20.0, 20.0), rng.uniform(-180.0, 180.0)});
  }
  const double swing = rng.uniform(-180.0, 180.0);
  d.comment = "boxes tilted up to 20 deg about both horizontal axes, scattered round the crane";
  d.task = crane_task(l);
  return set_endpoints(d, crane_low_pose(rng, l, swing, rng.uniform(11.0, 18.0)),
                       crane_low_pose(rng, l, swing + rng.sign() * rng.uniform(90.0, 180.0), rng.uniform(11.0, 18.0)));
}

bool crane_silos_rack(SiteRng& rng, const DrawContext&, Draft& d) {
  const CraneLoad l = crane_load(rng, 5000, 9000);
  const int silos = rng.integer(2, 4);
  for (int i = 0; i < silos; ++i) {
    const double at = rng.uniform(-60.0, 60.0) * kDeg, rho = rng.uniform(14.0, 26.0), h = rng.uniform(15.0, 25.0);
    round_shape(d, "cylinder", "silo-" + std::to_string(i + 1), rng.uniform(2.5, 4.0), h, {rho * std::cos(at), rho * std::sin(at), 0.5 * h});
  }
  // The rack runs north-south west of the crane: portal posts every 6 m, a beam on each side and
  // pipes along the top.
  const double xr = -rng.uniform(10.0, 14.0), length = rng.uniform(24.0, 30.0), h = rng.uniform(6.0, 8.0);
  const int bays = static_cast<int>(length / 6.0);
  for (int i = 0; i <= bays; ++i) {
    const double y = -0.5 * length + length * i / bays;
    for (const double side : {-1.0, 1.0}) block(d, "rack-post-" + std::to_string(i + 1) + (side < 0 ? "w" : "e"), xr + side, y, 0.4, 0.4, h);
  }
  for (const double side : {-1.0, 1.0}) box(d, std::string("rack-beam-") + (side < 0 ? "w" : "e"), {0.3, length, 0.4}, {xr + side, 0.0, h - 0.2});
  const int pipes = rng.integer(2, 3);
  for (int i = 0; i < pipes; ++i) {
    round_shape(d, "capsule", "pipe-" + std::to_string(i + 1), 0.3, length, {xr - 0.7 + 0.7 * i, 0.0, h + 0.3}, {90.0, 0.0, 0.0});
  }
  const double sx = xr - rng.uniform(3.0, 6.0), sy = rng.uniform(-8.0, 8.0);
  d.comment = "silos east of the crane, a pipe rack west; pick beyond the rack, set down among the silos";
  d.task = crane_task(l);
  const double sr = std::hypot(sx, sy);
  return set_endpoints(d, crane_pose(l, std::atan2(sy, sx) / kDeg, sr, rng.uniform(0.3, 1.0), rng.uniform(sr + 2.0, sr + 8.0)),
                       crane_low_pose(rng, l, rng.uniform(-70.0, 70.0), rng.uniform(12.0, 24.0)));
}

//! The 110-ft boom at most 1.5 deg above the chart's minimum elevation for the load.
bool crane_110ft_min_angle(SiteRng& rng, const DrawContext& context, Draft& d) {
  const CraneLoad l = crane_load(rng, 8000, 16000);
  if (context.crane_chart == nullptr) return false;
  const planning::LoadChartRule rule(*context.crane_chart, l.lb);
  const planning::ConstraintVerdict v = rule.min_elevation(kCraneBoomMaxM);
  if (!v.ok()) return false;
  const double min_deg = v.limit / kDeg;
  const double swing = rng.uniform(-180.0, 180.0), delta = rng.sign() * rng.uniform(60.0, 150.0);
  const double at = (swing + 0.5 * delta) * kDeg, rho = rng.uniform(15.0, 22.0);
  block(d, "building", rho * std::cos(at), rho * std::sin(at), rng.uniform(6.0, 10.0), rng.uniform(6.0, 10.0),
        rng.uniform(10.0, 20.0), wrap_deg(at / kDeg));
  const auto pose = [&](double swing_deg) -> std::optional<std::string> {
    const double e = min_deg + rng.uniform(0.3, 1.5);
    const double cable = kCraneFootM + kCraneBoomMaxM * std::sin(e * kDeg) - rng.uniform(0.5, 3.0) - l.sz - l.sling_m;
    if (cable < kCraneCableMinM || cable > kCraneCableMaxM || e > kCraneElevationMaxDeg) return std::nullopt;
    return crane_joints(swing_deg, e, kCraneBoomMaxM, cable);
  };
  d.comment = "the 110-ft boom within 1.5 deg of the chart's minimum elevation (" + num(min_deg) + " deg for " + num(l.lb) +
              " lb), a building between pick and set-down";
  d.task = crane_task(l);
  return set_endpoints(d, pose(swing), pose(swing + delta));
}

//! The goal on the 110-ft boom 5-15 deg below the chart's minimum elevation: refused by the chart.
bool crane_chart_infeasible(SiteRng& rng, const DrawContext& context, Draft& d) {
  const CraneLoad l = crane_load(rng, 14000, 20000);
  if (context.crane_chart == nullptr) return false;
  const planning::LoadChartRule rule(*context.crane_chart, l.lb);
  const planning::ConstraintVerdict v = rule.min_elevation(kCraneBoomMaxM);
  if (!v.ok()) return false;
  const double swing = rng.uniform(-180.0, 180.0);
  const double at = (swing + 180.0) * kDeg, rho = rng.uniform(15.0, 22.0);
  block(d, "building", rho * std::cos(at), rho * std::sin(at), rng.uniform(6.0, 10.0), rng.uniform(6.0, 10.0), rng.uniform(8.0, 16.0));
  const double start_boom = rng.uniform(15.0, 20.0), start_e = rng.uniform(55.0, 70.0);
  const double start_cable = kCraneFootM + start_boom * std::sin(start_e * kDeg) - rng.uniform(0.3, 1.0) - l.sz - l.sling_m;
  const double goal_e = v.limit / kDeg - rng.uniform(5.0, 15.0);
  const double goal_cable = kCraneFootM + kCraneBoomMaxM * std::sin(goal_e * kDeg) - rng.uniform(0.3, 1.0) - l.sz - l.sling_m;
  if (goal_e < 0.0 || start_cable < kCraneCableMinM || goal_cable < kCraneCableMinM) return false;
  d.comment = "the goal on the 110-ft boom at " + num(goal_e) + " deg, below the chart's " + num(v.limit / kDeg) + " deg for " +
              num(l.lb) + " lb: refused by the load chart";
  d.task = crane_task(l);
  d.start = crane_joints(swing, start_e, start_boom, start_cable);
  d.goal = crane_joints(swing + rng.sign() * rng.uniform(60.0, 150.0), goal_e, kCraneBoomMaxM, goal_cable);
  return true;
}

//! The crane in a hall: a roof too low to raise the boom over the partitions north and south of
//! the swing axis, start east of them, goal west. No path exists.
bool crane_walled_in(SiteRng& rng, const DrawContext&, Draft& d) {
  const CraneLoad l = crane_load(rng, 5000, 10000);
  const double roof = rng.uniform(8.5, 10.0), half = 22.0, inner = 5.5;
  box(d, "roof", {2.0 * half, 2.0 * half, 0.5}, {0.0, 0.0, roof + 0.25});
  for (const double side : {-1.0, 1.0}) {
    box(d, std::string("wall-") + (side > 0 ? "east" : "west"), {0.5, 2.0 * half, roof}, {side * half, 0.0, 0.5 * roof});
    box(d, std::string("wall-") + (side > 0 ? "north" : "south"), {2.0 * half, 0.5, roof}, {0.0, side * half, 0.5 * roof});
    box(d, std::string("partition-") + (side > 0 ? "north" : "south"), {0.5, half - inner, roof},
        {0.0, side * 0.5 * (half + inner), 0.5 * roof});
  }
  const auto pose = [&](double swing_deg) -> std::optional<std::string> {
    const double boom = rng.uniform(11.0, 13.0);
    const double max_e = std::asin(std::min(1.0, (roof - 1.5 - kCraneFootM) / boom)) / kDeg;
    if (max_e < 6.0) return std::nullopt;
    const double e = rng.uniform(5.0, max_e);
    return crane_pose(l, swing_deg, boom * std::cos(e * kDeg), rng.uniform(0.3, 1.0), boom);
  };
  d.comment = "the crane in a hall whose roof (" + num(roof) +
              " m) keeps the boom below partitions north and south of it; start east, goal west: no path";
  d.task = crane_task(l);
  return set_endpoints(d, pose(rng.uniform(-60.0, 60.0)), pose(rng.uniform(120.0, 240.0)));
}

// ---- Tower crane --------------------------------------------------------------------------------

struct TowerLoad {
  double sx = 0.0, sy = 0.0, sz = 0.0, sling_m = 0.0;
};

TowerLoad tower_load(SiteRng& rng, Draft& d) {
  TowerLoad l{rng.uniform(2.0, 4.0), rng.uniform(1.5, 2.5), rng.uniform(1.0, 2.0), rng.uniform(2.0, 3.0)};
  d.task = "  load_size_m: " + vec(l.sx, l.sy, l.sz) + "\n  sling_length_m: " + num(l.sling_m) + "\n";
  return l;
}

std::optional<std::string> tower_pose(const TowerLoad& l, double slew_deg, double r_m, double bottom_m) {
  const double hook = bottom_m + l.sz + l.sling_m;
  if (r_m < kTowerTrolleyMinM || r_m > kTowerTrolleyMaxM || hook > kTowerHookMaxM) return std::nullopt;
  return "  slew_deg: " + num(wrap_deg(slew_deg)) + "\n  trolley_radius_m: " + num(r_m) + "\n  hook_height_m: " + num(hook) + "\n";
}

std::optional<std::string> tower_low_pose(SiteRng& rng, const TowerLoad& l, double slew_deg, double r_m) {
  return tower_pose(l, slew_deg, r_m, rng.uniform(0.3, 1.5));
}

bool tower_buildings(SiteRng& rng, const DrawContext&, Draft& d) {
  const TowerLoad l = tower_load(rng, d);
  const int n = rng.integer(3, 6);
  for (int i = 0; i < n; ++i) {
    const double at = rng.uniform(-180.0, 180.0) * kDeg, rho = rng.uniform(14.0, 50.0);
    block(d, "building-" + std::to_string(i + 1), rho * std::cos(at), rho * std::sin(at), rng.uniform(8.0, 18.0),
          rng.uniform(8.0, 18.0), rng.uniform(8.0, 35.0), rng.uniform(-90.0, 90.0));
  }
  const double slew = rng.uniform(-180.0, 180.0);
  d.comment = "buildings 8-35 m tall under the jib";
  return set_endpoints(d, tower_low_pose(rng, l, slew, rng.uniform(12.0, 55.0)),
                       tower_low_pose(rng, l, slew + rng.sign() * rng.uniform(60.0, 180.0), rng.uniform(12.0, 55.0)));
}

bool tower_neighbour(SiteRng& rng, const DrawContext&, Draft& d) {
  const TowerLoad l = tower_load(rng, d);
  const double phi = rng.uniform(-180.0, 180.0), dist = rng.uniform(40.0, 55.0);
  const double mx = dist * std::cos(phi * kDeg), my = dist * std::sin(phi * kDeg);
  const double mast_h = rng.uniform(28.0, 40.0), jib = rng.uniform(35.0, 50.0), psi = rng.uniform(-180.0, 180.0);
  const double c = std::cos(psi * kDeg), s = std::sin(psi * kDeg);
  block(d, "crane-2-mast", mx, my, 1.6, 1.6, mast_h + 1.5, psi);
  box(d, "crane-2-jib", {jib, 1.2, 1.5}, {mx + 0.5 * jib * c, my + 0.5 * jib * s, mast_h + 0.75}, {0.0, 0.0, psi});
  box(d, "crane-2-counter-jib", {12.0, 1.2, 1.5}, {mx - 6.0 * c, my - 6.0 * s, mast_h + 0.75}, {0.0, 0.0, psi});
  const double trolley = rng.uniform(10.0, jib - 5.0), drop = rng.uniform(8.0, 18.0);
  round_shape(d, "capsule", "crane-2-hoist-line", 0.15, drop, {mx + trolley * c, my + trolley * s, mast_h - 0.5 * drop});
  d.comment = "a neighbouring tower crane's mast, jib and hoist line " + num(dist) + " m away, its jib below ours";
  return set_endpoints(d, tower_low_pose(rng, l, phi - rng.uniform(25.0, 70.0), rng.uniform(15.0, 55.0)),
                       tower_low_pose(rng, l, phi + rng.uniform(25.0, 70.0), rng.uniform(15.0, 55.0)));
}

bool tower_courtyard(SiteRng& rng, const DrawContext&, Draft& d) {
  const TowerLoad l = tower_load(rng, d);
  const double phi = rng.uniform(-180.0, 180.0), rho = rng.uniform(25.0, 40.0);
  const double cx = rho * std::cos(phi * kDeg), cy = rho * std::sin(phi * kDeg);
  const double court = rng.uniform(10.0, 16.0), wing = rng.uniform(6.0, 10.0), h = rng.uniform(12.0, 25.0);
  const double c = std::cos(phi * kDeg), s = std::sin(phi * kDeg);
  const double off = 0.5 * (court + wing), len = court + 2.0 * wing;
  // Four wings round the courtyard, aligned with the radius to it.
  const auto wing_at = [&](const std::string& name, double along, double across, double sx, double sy) {
    block(d, name, cx + along * c - across * s, cy + along * s + across * c, sx, sy, h, phi);
  };
  wing_at("wing-near", -off, 0.0, wing, len);
  wing_at("wing-far", off, 0.0, wing, len);
  wing_at("wing-left", 0.0, off, court, wing);
  wing_at("wing-right", 0.0, -off, court, wing);
  d.comment = "a building round a courtyard " + num(court) + " m across; the set-down in the courtyard";
  const double gx = cx + rng.uniform(-1.5, 1.5), gy = cy + rng.uniform(-1.5, 1.5);
  return set_endpoints(d, tower_low_pose(rng, l, phi + rng.sign() * rng.uniform(60.0, 180.0), rng.uniform(12.0, 50.0)),
                       tower_low_pose(rng, l, std::atan2(gy, gx) / kDeg, std::hypot(gx, gy)));
}

bool tower_trolley_slew(SiteRng& rng, const DrawContext&, Draft& d) {
  const TowerLoad l = tower_load(rng, d);
  const double phi = rng.uniform(-180.0, 180.0), inner = rng.uniform(24.0, 30.0), outer = 58.0;
  const double width = rng.uniform(12.0, 20.0);
  const double mid = 0.5 * (inner + outer);
  block(d, "high-rise", mid * std::cos(phi * kDeg), mid * std::sin(phi * kDeg), outer - inner, width, rng.uniform(43.0, 44.0), phi);
  d.comment = "a 43-44 m high-rise from " + num(inner) + " m out between pick (far out) and set-down (near the mast): trolley in, then slew";
  return set_endpoints(d, tower_low_pose(rng, l, phi - rng.uniform(25.0, 50.0), rng.uniform(45.0, 55.0)),
                       tower_low_pose(rng, l, phi + rng.uniform(25.0, 50.0), rng.uniform(12.0, 20.0)));
}

// ---- Excavator ----------------------------------------------------------------------------------

struct ExcPose {
  double swing = 0.0, boom = 0.0, arm = 0.0, bucket = 0.0;  //!< [deg]
};

//! Bucket tip in the swing plane: (reach from the swing axis, height above the ground) [m].
std::array<double, 2> bucket_tip(const ExcPose& p) {
  const double b = p.boom * kDeg, a = (p.boom + p.arm) * kDeg, k = (p.boom + p.arm + p.bucket) * kDeg;
  return {kExcFootForwardM + kExcBoomM * std::cos(b) + kExcArmM * std::cos(a) + kExcBucketM * std::cos(k),
          kExcFootHeightM + kExcBoomM * std::sin(b) + kExcArmM * std::sin(a) + kExcBucketM * std::sin(k)};
}

std::optional<std::string> exc_joints(const ExcPose& p) {
  const auto in = [](double v, const std::array<double, 2>& r) { return v >= r[0] && v <= r[1]; };
  if (!in(p.boom, kExcBoomRangeDeg) || !in(p.arm, kExcArmRangeDeg) || !in(p.bucket, kExcBucketRangeDeg)) return std::nullopt;
  return "  swing_deg: " + num(wrap_deg(p.swing)) + "\n  boom_deg: " + num(p.boom) + "\n  arm_deg: " + num(p.arm) +
         "\n  bucket_deg: " + num(p.bucket) + "\n";
}

//! The bucket in the trench in front: tip 1-2 m below the ground.
ExcPose dig_pose(SiteRng& rng, double swing_deg) {
  return {swing_deg, rng.uniform(-15.0, -5.0), rng.uniform(-90.0, -70.0), rng.uniform(-100.0, -80.0)};
}

//! The full bucket carried level (ground angle -175..-185 deg) at dumping height.
ExcPose dump_pose(SiteRng& rng, double swing_deg) {
  ExcPose p{swing_deg, rng.uniform(25.0, 35.0), rng.uniform(-55.0, -45.0), 0.0};
  p.bucket = rng.uniform(-185.0, -175.0) - p.boom - p.arm;
  return p;
}

//! A tipper under the bucket of `dump`: the bed's top 0.5-0.9 m below the bucket tip.
void truck_under(SiteRng& rng, Draft& d, const std::string& name, const ExcPose& dump) {
  const auto tip = bucket_tip(dump);
  const double at = dump.swing * kDeg, yaw = dump.swing + ((rng.next() & 1U) != 0U ? 90.0 : 0.0);
  const double bed_h = std::clamp(tip[1] - rng.uniform(0.5, 0.9), 2.2, 3.2), bed_len = rng.uniform(5.5, 7.0);
  const double along = rng.uniform(-1.0, 1.0);
  const double c = std::cos(yaw * kDeg), s = std::sin(yaw * kDeg);
  const double bx = tip[0] * std::cos(at) + along * c, by = tip[0] * std::sin(at) + along * s;
  block(d, name + "-bed", bx, by, bed_len, 2.5, bed_h, yaw);
  const double cab = 0.5 * bed_len + 1.5;
  block(d, name + "-cab", bx - cab * c, by - cab * s, 2.5, 2.5, 3.5, yaw);
}

void pipelines(SiteRng& rng, Draft& d) {
  const double p = rng.uniform(1.6, 2.2), radius = rng.uniform(0.3, 0.6), length = rng.uniform(6.0, 10.0), x = rng.uniform(6.0, 8.0);
  for (const double side : {-1.0, 1.0}) {
    round_shape(d, "cylinder", std::string("pipeline-") + (side > 0 ? "left" : "right"), radius, length, {x, side * p, radius},
                {0.0, 90.0, 0.0});
  }
}

bool exc_trench_pipelines(SiteRng& rng, const DrawContext&, Draft& d) {
  pipelines(rng, d);
  const ExcPose dump = dump_pose(rng, rng.sign() * rng.uniform(80.0, 100.0));
  truck_under(rng, d, "truck", dump);
  d.comment = "digging a trench between two pipelines, loading a truck to the side";
  return set_endpoints(d, exc_joints(dig_pose(rng, rng.uniform(-3.0, 3.0))), exc_joints(dump));
}

bool exc_tail_wall(SiteRng& rng, const DrawContext&, Draft& d) {
  // A wall at 2.6-2.95 m on the right: the house's tail (3.15 m swing radius) cannot pass it, so
  // the swing to a truck behind-left goes the long way round, through the right.
  const double wall = rng.uniform(2.6, 2.95);
  block(d, "wall", rng.uniform(-0.5, 0.5), -wall - 0.25, rng.uniform(5.0, 7.0), 0.5, rng.uniform(2.5, 4.0));
  const ExcPose dump = dump_pose(rng, rng.uniform(135.0, 170.0));
  truck_under(rng, d, "truck", dump);
  d.comment = "a wall " + num(wall) + " m right of the swing axis, inside the tail's swing: the swing to the truck goes the long way";
  return set_endpoints(d, exc_joints(dig_pose(rng, rng.uniform(-20.0, 20.0))), exc_joints(dump));
}

bool exc_power_line(SiteRng& rng, const DrawContext&, Draft& d) {
  const double h = rng.uniform(6.5, 8.0), x = rng.uniform(3.0, 6.0);
  for (int i = 0; i < 2; ++i) {
    round_shape(d, "capsule", "conductor-" + std::to_string(i + 1), 0.1, 40.0, {x + 0.8 * i, 0.0, h + 0.5 * i}, {90.0, 0.0, 0.0});
  }
  const ExcPose dump = dump_pose(rng, rng.sign() * rng.uniform(70.0, 110.0));
  truck_under(rng, d, "truck", dump);
  d.comment = "a power line " + num(h) + " m above the dig, loading a truck to the side";
  return set_endpoints(d, exc_joints(dig_pose(rng, rng.uniform(-10.0, 10.0))), exc_joints(dump));
}

bool exc_hopper(SiteRng& rng, const DrawContext&, Draft& d) {
  // The bucket hangs down into the hopper's opening, its tip below the rim.
  ExcPose goal{rng.sign() * rng.uniform(60.0, 120.0), rng.uniform(10.0, 30.0), rng.uniform(-80.0, -50.0), 0.0};
  goal.bucket = rng.uniform(-120.0, -95.0) - goal.boom - goal.arm;
  const auto tip = bucket_tip(goal);
  const double opening = rng.uniform(2.2, 3.0), rim = tip[1] + rng.uniform(0.2, 0.6), t = 0.3;
  if (rim < 1.5) return false;
  const double at = goal.swing * kDeg, c = std::cos(at), s = std::sin(at);
  const double hx = tip[0] * c, hy = tip[0] * s, off = 0.5 * (opening + t), len = opening + 2.0 * t;
  const auto wall = [&](const std::string& name, double along, double across, double sx, double sy) {
    block(d, name, hx + along * c - across * s, hy + along * s + across * c, sx, sy, rim, goal.swing);
  };
  wall("hopper-near", -off, 0.0, t, len);
  wall("hopper-far", off, 0.0, t, len);
  wall("hopper-left", 0.0, off, opening, t);
  wall("hopper-right", 0.0, -off, opening, t);
  d.comment = "a hopper with a " + num(opening) + " m opening, rim " + num(rim) + " m high; the bucket goes in from above";
  return set_endpoints(d, exc_joints(dig_pose(rng, rng.uniform(-20.0, 20.0))), exc_joints(goal));
}

bool exc_truck_layout(SiteRng& rng, const DrawContext&, Draft& d) {
  const ExcPose dump = dump_pose(rng, rng.sign() * rng.uniform(60.0, 180.0));
  truck_under(rng, d, "truck", dump);
  // A second truck waiting, and a spoil heap, somewhere the bucket may pass.
  const ExcPose waiting = dump_pose(rng, dump.swing + rng.sign() * rng.uniform(40.0, 90.0));
  truck_under(rng, d, "truck-waiting", waiting);
  const double at = rng.uniform(-180.0, 180.0) * kDeg, rho = rng.uniform(6.0, 9.0), heap = rng.uniform(1.0, 2.5);
  block(d, "spoil-heap", rho * std::cos(at), rho * std::sin(at), rng.uniform(2.0, 4.0), rng.uniform(2.0, 4.0), heap);
  d.comment = "a truck to load, a second one waiting and a spoil heap round the excavator";
  return set_endpoints(d, exc_joints(dig_pose(rng, rng.uniform(-15.0, 15.0))), exc_joints(dump));
}

using DrawFn = bool (*)(SiteRng&, const DrawContext&, Draft&);

struct FamilyEntry {
  SiteFamily family;
  DrawFn draw;
};

const std::vector<FamilyEntry>& family_entries() {
  using E = SiteExpectation;
  static const std::vector<FamilyEntry> all = {
      {{"crane-l-frame", "grove-tms870.yaml", E::Solvable, "L-shaped steel frame, goal low in its inner corner"}, crane_l_frame},
      {{"crane-rotated-frame", "grove-tms870.yaml", E::Solvable, "steel frame turned 15-75 deg"}, crane_rotated_frame},
      {{"crane-tower-gap", "grove-tms870.yaml", E::Solvable, "5 m gap between two 40 m towers"}, crane_tower_gap},
      {{"crane-roof-telescope", "grove-tms870.yaml", E::Solvable, "boom ~11 m to ~30 m onto a roof"}, crane_roof_telescope},
      {{"crane-long-swing", "grove-tms870.yaml", E::Solvable, "swing of 175 or 180 deg past a building"}, crane_long_swing},
      {{"crane-tilted-boxes", "grove-tms870.yaml", E::Solvable, "4-7 tilted boxes"}, crane_tilted_boxes},
      {{"crane-silos-rack", "grove-tms870.yaml", E::Solvable, "silos and a pipe rack"}, crane_silos_rack},
      {{"crane-110ft-min-angle", "grove-tms870.yaml", E::Solvable, "110-ft boom within 1.5 deg of the chart minimum"}, crane_110ft_min_angle},
      {{"crane-chart-infeasible", "grove-tms870.yaml", E::ChartInfeasible, "goal below the chart's minimum elevation"}, crane_chart_infeasible},
      {{"crane-walled-in", "grove-tms870.yaml", E::WalledIn, "crane in a low hall split by partitions"}, crane_walled_in},
      {{"tower-buildings", "pecco-sk180.yaml", E::Solvable, "buildings under the jib"}, tower_buildings},
      {{"tower-neighbour", "pecco-sk180.yaml", E::Solvable, "a neighbouring crane's mast, jib and hoist line"}, tower_neighbour},
      {{"tower-courtyard", "pecco-sk180.yaml", E::Solvable, "set-down in a courtyard"}, tower_courtyard},
      {{"tower-trolley-slew", "pecco-sk180.yaml", E::Solvable, "trolley in, then slew past a high-rise"}, tower_trolley_slew},
      {{"exc-trench-pipelines", "cat-320.yaml", E::Solvable, "trench between pipelines, truck to the side"}, exc_trench_pipelines},
      {{"exc-tail-wall", "cat-320.yaml", E::Solvable, "wall inside the tail swing, the long way round"}, exc_tail_wall},
      {{"exc-power-line", "cat-320.yaml", E::Solvable, "power line over the dig"}, exc_power_line},
      {{"exc-hopper", "cat-320.yaml", E::Solvable, "hopper with a narrow opening"}, exc_hopper},
      {{"exc-truck-layout", "cat-320.yaml", E::Solvable, "truck, a waiting truck and a spoil heap"}, exc_truck_layout},
  };
  return all;
}

const FamilyEntry& entry_of(const SiteFamily& family) {
  for (const FamilyEntry& e : family_entries()) {
    if (e.family.name == family.name) return e;
  }
  throw std::invalid_argument("unknown site family '" + family.name + "'");
}

std::string capitalised(std::string text) {
  if (!text.empty() && text[0] >= 'a' && text[0] <= 'z') text[0] = static_cast<char>(text[0] - 'a' + 'A');
  return text;
}

//! The whole file: the draft inside what every generated site shares.
std::string scenario_text(const SiteFamily& family, std::uint64_t seed, const std::string& name, const Draft& d) {
  const bool excavator = family.machine == "cat-320.yaml";
  const bool tower = family.machine == "pecco-sk180.yaml";
  std::string text = "# Generated by mgc-bench's site generator (docs/sites.md): family " + family.name + ", seed " +
                     std::to_string(seed) + ".\n# " + capitalised(d.comment) + ".\n# Replay a query: mgc-plan --scenario <this file> --planner P --seed S\n";
  text += "name: " + name + "\ndescription: " + family.description + "\nmachine: machines/" + family.machine +
          "\nbase:\n  position_m: [0, 0, 0]\n  yaw_deg: 0\n";
  if (!d.task.empty()) text += "task:\n" + d.task;
  text += d.obstacles.empty() ? "obstacles: []\n" : "obstacles:\n" + d.obstacles;
  if (!d.dynamic.empty()) text += "dynamic_obstacles:\n" + d.dynamic;
  text += "start:\n" + d.start + "goal:\n" + d.goal;
  text += "planner:\n  seed: 0\n  max_iterations: " + std::to_string(kSiteMaxIterations) +
          "\n  goal_bias: 0.1\n  space_resolution: " + std::string(tower ? "150" : excavator ? "100" : "50") +
          "\n  error_tolerance: 1.0\n  dilation_m: 0.15\n  replan_max_iterations: 2000\n  replan_goal_bias: 0.15\n";
  // An excavator works within half a metre of the truck it loads: mgc's crane margins would
  // leave it no valid goal (docs/scenario-format.md, guidance).
  if (excavator) {
    text += "guidance:\n  stop_margin_m: 0.05\n  warning_margin_m: 0.25\n  planning_margin_m: 0.35\n  escape_margin_m: 0.3\n";
  }
  return text;
}


//! The tool point (hook, bucket tip) of q in the world.
Eigen::Vector3d tool_point(const planning::MachineModel& model, const planning::JointVector& q) {
  planning::Kinematics k;
  model.forward_kinematics(q, k);
  const int i = model.key_point_index(model.kind() == planning::MachineKind::Excavator ? "bucket_tip" : "hook");
  return k.points[static_cast<std::size_t>(i)];
}

//! A second machine that drives in and parks on the bearing halfway between the start's and the
//! goal's tool points (generate_intruder_site).
void add_intruder(SiteRng& rng, const planning::io::LoadedScenario& loaded, Draft& d) {
  const planning::MachineModel& model = *loaded.model;
  const Eigen::Vector3d a = tool_point(model, loaded.scenario.start), b = tool_point(model, loaded.scenario.goal);
  const double ra = std::hypot(a.x(), a.y()), rb = std::hypot(b.x(), b.y());
  Eigen::Vector2d mid(a.x() / std::max(ra, 1e-9) + b.x() / std::max(rb, 1e-9), a.y() / std::max(ra, 1e-9) + b.y() / std::max(rb, 1e-9));
  // Start and goal opposite each other: the halfway bearing either side, drawn.
  if (mid.norm() < 0.1) mid = rng.sign() * Eigen::Vector2d(-a.y(), a.x());
  const double bearing = std::atan2(mid.y(), mid.x());
  const bool excavator = model.kind() == planning::MachineKind::Excavator;
  const bool tower = model.kind() == planning::MachineKind::TowerCrane;
  // It drives along the tangent at the parking point, so it passes the machine's own body (the
  // excavator's house swings within 3.2 m, the crane's carrier reaches 8.5 m) and stops across the
  // tool's way between pick and set-down.
  const double park_r = std::max(0.5 * (ra + rb), excavator ? 5.0 : tower ? 8.0 : 10.0);
  const double from_r = excavator ? 18.0 : tower ? 68.0 : 45.0;
  const double approach = bearing + rng.sign() * 0.5 * std::numbers::pi;
  const double px = park_r * std::cos(bearing), py = park_r * std::sin(bearing);
  const double fx = px + from_r * std::cos(approach), fy = py + from_r * std::sin(approach);
  const double heading = std::atan2(py - fy, px - fx) / kDeg;
  const double speed = excavator ? 4.0 : 2.0;  // m/s: a tipper on site, a crane driving in
  const double drive_s = from_r / speed;
  // Half a second parked at the start at least: the script's times rise strictly.
  const double arrive_s = drive_s + 0.5 + (excavator ? rng.uniform(0.0, 2.0) : rng.uniform(0.0, 30.0));
  if (excavator) {
    d.dynamic += "  - name: truck-2\n    parts:\n"
                 "      - {type: box, size_m: [4.6, 2.5, 2.6], position_m: [-1.0, 0, 1.9]}\n"
                 "      - {type: box, size_m: [2.0, 2.5, 3.2], position_m: [2.4, 0, 1.6]}\n"
                 "      - {type: box, size_m: [6.8, 2.3, 0.6], position_m: [0.0, 0, 0.6]}\n";
  } else {
    // A mobile crane with its 16 m boom raised at 45 deg over the cab, hook and load at 10 m.
    d.dynamic += "  - name: crane-2\n    parts:\n"
                 "      - {type: box, size_m: [10.0, 2.6, 3.0], position_m: [0, 0, 1.5]}\n"
                 "      - {type: box, size_m: [16.0, 0.9, 1.1], position_m: [5.66, 0, 8.66], rpy_deg: [0, -45, 0]}\n"
                 "      - {type: capsule, radius_m: 0.1, length_m: 4.0, position_m: [11.31, 0, 12.31]}\n"
                 "      - {type: box, size_m: [2.0, 2.0, 2.0], position_m: [11.31, 0, 9.31]}\n";
  }
  d.dynamic += "    motion:\n      - {t_s: 0, position_m: " + vec(fx, fy, 0.0) + ", yaw_deg: " + num(heading) + "}\n" +
               "      - {t_s: " + num(arrive_s - drive_s) + ", position_m: " + vec(fx, fy, 0.0) + ", yaw_deg: " + num(heading) + "}\n" +
               "      - {t_s: " + num(arrive_s) + ", position_m: " + vec(px, py, 0.0) + ", yaw_deg: " + num(heading) + "}\n";
  d.comment += "; " + std::string(excavator ? "a truck" : "a second crane") + " drives in " + num(from_r) + " m and parks at " +
               num(arrive_s) + " s, " + num(park_r) + " m out on the bearing between pick and set-down";
}

bool meets(SiteExpectation expectation, planning::io::LoadedScenario& loaded) {
  const Validity start = loaded.world->validate(loaded.scenario.start);
  const Validity goal = loaded.world->validate(loaded.scenario.goal);
  if (!start.valid()) return false;
  if (expectation != SiteExpectation::ChartInfeasible) return goal.valid();
  return goal.status == Validity::Status::Constraint && goal.constraint.chart_row >= 0;
}

}  // namespace

const char* to_string(SiteExpectation expectation) noexcept {
  switch (expectation) {
    case SiteExpectation::Solvable: return "solvable";
    case SiteExpectation::ChartInfeasible: return "chart-infeasible";
    case SiteExpectation::WalledIn: return "walled-in";
  }
  return "?";
}

const std::vector<SiteFamily>& site_families() {
  static const std::vector<SiteFamily> all = [] {
    std::vector<SiteFamily> v;
    for (const FamilyEntry& e : family_entries()) v.push_back(e.family);
    return v;
  }();
  return all;
}

const SiteFamily* find_site_family(const std::string& name) {
  for (const SiteFamily& f : site_families()) {
    if (f.name == name) return &f;
  }
  return nullptr;
}

namespace {

GeneratedSite generate(const SiteFamily& family, std::uint64_t seed, const std::filesystem::path& machines_dir,
                       const std::filesystem::path& out_dir, bool with_intruder) {
  const FamilyEntry& entry = entry_of(family);
  const std::filesystem::path machine_source = machines_dir / family.machine;
  const std::filesystem::path machine_copy = out_dir / "machines" / family.machine;
  // Read first: a missing or broken machine file is reported as the loader reports it.
  const std::optional<planning::LoadChart> chart = planning::io::load_machine(machine_source).load_chart;
  DrawContext context;
  context.crane_chart = chart ? &*chart : nullptr;
  std::filesystem::create_directories(machine_copy.parent_path());
  std::error_code error;
  std::filesystem::copy_file(machine_source, machine_copy, std::filesystem::copy_options::overwrite_existing, error);
  if (error) throw std::runtime_error(machine_copy.string() + ": cannot copy the machine file there: " + error.message());
  GeneratedSite site;
  site.family = find_site_family(family.name);
  site.seed = seed;
  const std::string name = family.name + "-s" + std::to_string(seed) + (with_intruder ? "-intruder" : "");
  site.file = out_dir / (name + ".yaml");
  SiteRng rng(family_hash(family.name) ^ (seed * 0xD1B54A32D192ED03ULL));
  for (int draw = 1; draw <= kSiteMaxDraws; ++draw) {
    Draft d;
    if (!entry.draw(rng, context, d)) continue;
    write_text(site.file, scenario_text(family, seed, name, d));
    planning::io::LoadedScenario loaded;
    try {
      loaded = planning::io::load_and_build(site.file);
    } catch (const planning::io::InputError& e) {
      // A start or goal drawn outside a joint's range is a draw to redraw; anything else is ours.
      if (e.field().rfind("start", 0) == 0 || e.field().rfind("goal", 0) == 0) continue;
      throw;
    }
    if (!meets(family.expectation, loaded)) continue;
    if (with_intruder) {
      add_intruder(rng, loaded, d);
      write_text(site.file, scenario_text(family, seed, name, d));
      loaded = planning::io::load_and_build(site.file);
      if (!meets(family.expectation, loaded)) continue;
    }
    site.draws = draw;
    return site;
  }
  std::filesystem::remove(site.file, error);
  throw std::runtime_error("site family " + family.name + ", seed " + std::to_string(seed) + ": no draw of " +
                           std::to_string(kSiteMaxDraws) + " met its expectation (" + to_string(family.expectation) + ")");
}

}  // namespace

GeneratedSite generate_site(const SiteFamily& family, std::uint64_t seed, const std::filesystem::path& machines_dir,
                            const std::filesystem::path& out_dir) {
  return generate(family, seed, machines_dir, out_dir, false);
}

GeneratedSite generate_intruder_site(const SiteFamily& family, std::uint64_t seed, const std::filesystem::path& machines_dir,
                                     const std::filesystem::path& out_dir) {
  return generate(family, seed, machines_dir, out_dir, true);
}

}  // namespace mgc::bench

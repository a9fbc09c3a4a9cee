// SPDX-License-Identifier: Apache-2.0
// A stale site member posed from the site's UWB tags on it (docs/site.md, "Staleness"): the fit of
// its joints through its model from the tags' fixes, its velocity, and every way it refuses to pose
// the machine (no fresh fix, a tag off the model, a jump beyond the speed bound), in stepped time.

#include "mgc/firmware/site_member.hpp"
#include "mgc/planning/io/site_loader.hpp"
#include "mgc/planning/machine_model.hpp"
#include "mgc/sim/site_simulation.hpp"

#include <catch2/catch.hpp>

#include <array>
#include <cmath>
#include <optional>
#include <string>
#include <vector>

using namespace mgc;

namespace {

constexpr std::int64_t kT0_us = 10'000'000;
constexpr std::int64_t kCycle_us = 10'000;

//! The example site: the TMS870 (machine 1) and the tower crane (machine 2) with tags 1..4 on the
//! jib tip, the trolley, the counterweight and the hook.
firmware::SiteMemberConfig tms_member() {
  firmware::SiteMemberConfig c;
  c.site = planning::io::load_site(std::string(MGC_SOURCE_DIR) + "/scenarios/sites/thesis-steel-frame.yaml");
  c.machine_id = 1;
  return c;
}

struct Fixture {
  firmware::SiteMemberConfig config = tms_member();
  std::unique_ptr<planning::MachineModel> mine = planning::build_model(planning::lift_scenario(config.site, 0, 0));
  std::vector<firmware::SitePeerModel> peers = firmware::make_site_peers(config, *mine, 0);
  firmware::SitePeerModel& tower = peers.at(0);
  hal::SensorSnapshot snap{};

  //! Every tag fixed at q now (received at now_us), plus offset_m on tag `moved` (0: none).
  void fix(const planning::JointVector& q, std::int64_t now_us, int moved = 0, Eigen::Vector3d offset_m = Eigen::Vector3d::Zero(),
           int missing = 0) {
    planning::Kinematics k;
    tower.model->forward_kinematics(q, k);
    snap.num_tags = 0;
    for (int t = 0; t < tower.num_tags; ++t) {
      const auto u = static_cast<std::size_t>(t);
      if (tower.tag_ids[u] == missing) continue;
      hal::TagReading& r = snap.tags[snap.num_tags++];
      r.tag_id = tower.tag_ids[u];
      r.valid = true;
      Eigen::Vector3d at = planning::tag_position(k, tower.tag_mounts[u], tower.tag_local_m[u]);
      if (tower.tag_ids[u] == moved) at += offset_m;
      r.position_m = {at.x(), at.y(), at.z()};
      r.sigma_m = 0.1;
      r.t_us = now_us;
      r.updated = true;
    }
  }
};

planning::JointVector tower_q(double slew_rad, double trolley_m, double hook_m) {
  planning::JointVector q(3);
  q << slew_rad, trolley_m, hook_m;
  return q;
}

}  // namespace

TEST_CASE("site tags: the fit finds the joints, their velocity, and grows by what the tags cannot see", "[unit][uwb]") {
  Fixture f;
  REQUIRE(f.tower.num_tags == 4);
  const planning::JointVector seed = tower_q(0.0, 30.0, 4.5);
  // The tower crane slews at 0.05 rad/s and runs its trolley out at 0.4 m/s, the hoist still; the
  // fit starts from a seed 0.2 rad and 2 m off.
  const auto truth = [](std::int64_t t_us) {
    const double t_s = static_cast<double>(t_us - kT0_us) * 1e-6;
    return tower_q(0.2 + 0.05 * t_s, 28.0 + 0.4 * t_s, 4.5);
  };
  firmware::SiteTagPose pose;
  for (std::int64_t t = kT0_us; t <= kT0_us + 1'000'000; t += kCycle_us) {
    f.fix(truth(t), t);
    pose = firmware::site_fit_tags(f.tower, f.snap, seed, kT0_us - 100'000, t, f.config);
    // No velocity before half a window of fits: not yet a pose to use.
    if (t - kT0_us < f.config.tag_velocity_window_us / 2) CHECK_FALSE(pose.valid);
  }
  REQUIRE(pose.valid);
  CHECK(pose.tags_used == 4);
  const planning::JointVector q = truth(kT0_us + 1'000'000);
  CHECK(pose.q[0] == Approx(q[0]).margin(1e-4));
  CHECK(pose.q[1] == Approx(q[1]).margin(1e-3));
  CHECK(pose.q[2] == Approx(q[2]).margin(1e-3));
  CHECK(pose.v[0] == Approx(0.05).margin(1e-3));
  CHECK(pose.v[1] == Approx(0.4).margin(1e-2));
  CHECK(pose.v[2] == Approx(0.0).margin(1e-2));
  CHECK(pose.residual_m < 1e-3);
  // Every joint seen: the growth is the fixes' sigma and the latency at the speed bound.
  CHECK(pose.grow_m == Approx(3 * 0.1 + f.tower.max_point_speed_m_s * 0.1).margin(0.01));

  SECTION("without the hook's tag the hoist is unseen: it grows at the hoist's speed since a tag last saw it") {
    const std::int64_t seen_us = kT0_us + 1'000'000;
    f.fix(truth(seen_us + kCycle_us), seen_us + kCycle_us, 0, Eigen::Vector3d::Zero(), 4);
    pose = firmware::site_fit_tags(f.tower, f.snap, seed, kT0_us, seen_us + 2 * kCycle_us, f.config);
    REQUIRE(pose.valid);
    CHECK(pose.tags_used == 3);
    const double hoist_m_s = f.tower.model->joints()[2].max_velocity;
    // Seen by the hook's tag last at seen_us; 20 ms later, plus the latency.
    const double expect_m = 3 * 0.1 + pose.residual_m + f.tower.max_point_speed_m_s * (0.01 + 0.1) + hoist_m_s * (0.02 + 0.1);
    CHECK(pose.grow_m == Approx(expect_m).margin(0.01));
    CHECK(pose.v[2] == 0.0);
  }
  SECTION("a tag off the model (moved on the machine, a wrong fix): implausible, nothing posed") {
    const std::int64_t t = kT0_us + 1'010'000;
    f.fix(truth(t), t, 1, Eigen::Vector3d(0.0, 3.0, 0.0));
    pose = firmware::site_fit_tags(f.tower, f.snap, seed, kT0_us, t, f.config);
    CHECK_FALSE(pose.valid);
    CHECK(f.tower.tag_track.fits_implausible == 1);
  }
  SECTION("every tag jumped farther than the machine can move: implausible") {
    const std::int64_t t = kT0_us + 1'010'000;
    f.fix(truth(t) + tower_q(0.5, 0.0, 0.0), t);
    pose = firmware::site_fit_tags(f.tower, f.snap, seed, kT0_us, t, f.config);
    CHECK_FALSE(pose.valid);
    CHECK(f.tower.tag_track.fits_implausible == 1);
  }
  SECTION("fixes older than the limit: nothing to pose it by") {
    const std::int64_t t = kT0_us + 1'000'000 + f.config.tag_max_age_us + kCycle_us;
    pose = firmware::site_fit_tags(f.tower, f.snap, seed, kT0_us, t, f.config);
    CHECK_FALSE(pose.valid);
    CHECK(pose.tags_used == 0);
  }
}

TEST_CASE("mgc-sim --site: each machine's gateway reports the other machines' site tags where their true joints put them", "[unit][uwb]") {
  const planning::Site site = planning::io::load_site(std::string(MGC_SOURCE_DIR) + "/scenarios/sites/thesis-steel-frame.yaml");
  hal::ManualClock clock(1'000'000);
  auto a = hal::open_can_bus("loop:site-tags-1", &clock);
  auto b = hal::open_can_bus("loop:site-tags-2", &clock);
  REQUIRE(a);
  REQUIRE(b);
  const std::array<hal::CanBus*, 2> buses{a.bus.get(), b.bus.get()};
  sim::SiteSimulation world(site, buses, sim::SimConfig{}, std::nullopt);
  // The TMS870's simulator reports the tower crane's four tags; the tower crane's none (the TMS870 has none).
  REQUIRE(world.simulator(0).site_tags().size() == 4);
  CHECK(world.simulator(1).site_tags().empty());
  world.step(1'000'000);
  const auto tower = planning::build_model(planning::lift_scenario(site, 1, 0));
  planning::Kinematics k;
  planning::JointVector q(3);
  for (int j = 0; j < 3; ++j) q[j] = world.simulator(1).truth().position[static_cast<std::size_t>(j)];
  tower->forward_kinematics(q, k);
  for (const sim::SiteSimTag& t : world.simulator(0).site_tags()) {
    CAPTURE(static_cast<int>(t.tag_id));
    CHECK(world.simulator(0).site_tag_position(t).isApprox(planning::tag_position(k, t.mount, t.position_m), 1e-9));
  }
  // The trolley's tag at the lift's start: 30 m out along slew -30 deg from the mast at (-40, -10).
  const Eigen::Vector3d trolley = world.simulator(0).site_tag_position(world.simulator(0).site_tags()[1]);
  CHECK(std::hypot(trolley.x() + 40.0, trolley.y() + 10.0) == Approx(30.0).margin(1e-6));
  CHECK(std::atan2(trolley.y() + 10.0, trolley.x() + 40.0) == Approx(-30.0 * 3.14159265358979323846 / 180.0).margin(1e-6));
}

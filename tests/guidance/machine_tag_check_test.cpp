// SPDX-License-Identifier: Apache-2.0
// The machine's own UWB tags against forward kinematics of its encoders, in stepped time: exact
// fixes raise nothing, an offset beyond the threshold is found after exactly disagree_fixes fixes,
// fixes of unknown quality and stale tags are not judged.
#include <catch2/catch.hpp>

#include <array>
#include <memory>
#include <numbers>
#include <string>
#include <vector>

#include "mgc/guidance/diagnostics.hpp"
#include "mgc/planning/io/scenario_loader.hpp"

using namespace mgc;
using guidance::MachineTag;
using guidance::MachineTagCheck;
using guidance::MachineTagFix;
using guidance::MachineTagInputs;

namespace {

constexpr std::uint8_t kTipTag = 200;
constexpr std::int64_t kCycleUs = 10'000;
constexpr std::int64_t kFixEveryUs = 100'000;

//! The thesis crane with a tag at its boom tip: a clock, the joints and the tag's fixes by hand.
struct Bench {
  planning::Scenario scenario = planning::io::load_scenario(std::string(MGC_SOURCE_DIR) + "/scenarios/thesis-steel-frame.yaml");
  std::unique_ptr<planning::MachineModel> model = planning::build_model(scenario);
  std::vector<MachineTag> tags{{kTipTag, planning::resolve_tag_mount(*model, "boom_tip"), Eigen::Vector3d(0.0, 0.0, 0.3)}};
  std::unique_ptr<MachineTagCheck> check;
  planning::JointVector q = scenario.start;
  planning::JointVector v = planning::JointVector::Zero(scenario.start.size());  //!< [rad/s | m/s]
  std::int64_t now_us = 1'000'000;
  std::array<MachineTagFix, 2> fixes{};
  Eigen::Vector3d offset_m = Eigen::Vector3d::Zero();  //!< added to every fix
  std::uint8_t quality = 2;
  bool fixing = true;                                  //!< the gateway reports the tag
  int fixes_sent = 0;

  explicit Bench(const guidance::MachineTagCheckConfig& config = {}) {
    REQUIRE(tags[0].mount.index >= 0);
    check = std::make_unique<MachineTagCheck>(*model, tags, config);
    fixes[1].id = 7;  // an obstacle's tag: not the check's business
  }

  //! Where the tag truly is with the joints at q. [m]
  Eigen::Vector3d truth(const planning::JointVector& at) const {
    planning::Kinematics k;
    model->forward_kinematics(at, k);
    return planning::tag_position(k, tags[0].mount, tags[0].local_m);
  }

  //! One cycle: the joints move at v; a fix every 100 ms, ranged 25 ms before it is received (the
  //! middle of the protocol's 0..50 ms).
  const guidance::MachineTagResult& cycle() {
    now_us += kCycleUs;
    q += v * (static_cast<double>(kCycleUs) * 1e-6);
    MachineTagFix& fix = fixes[0];
    fix.id = kTipTag;
    fix.updated = fixing && now_us % kFixEveryUs == 0;
    if (fix.updated) {
      const Eigen::Vector3d p = truth(q - v * 0.025) + offset_m;
      fix.position_m = {p.x(), p.y(), p.z()};
      fix.quality = quality;
      fix.t_us = now_us;
      ++fixes_sent;
    }
    MachineTagInputs in;
    in.now_us = now_us;
    in.joints_valid = true;
    in.joints_t_us = now_us;
    for (int j = 0; j < q.size(); ++j) in.position[static_cast<std::size_t>(j)] = q[j];
    in.fixes = fixes;
    return check->update(in);
  }

  //! Runs until n more fixes were sent (or a finding). Returns the fixes it took.
  int run_fixes(int n) {
    const int from = fixes_sent;
    while (fixes_sent - from < n && !check->result().disagrees) (void)cycle();
    return fixes_sent - from;
  }
};

}  // namespace

TEST_CASE("machine tags: fixes where forward kinematics puts the tag raise nothing, at rest and at full speed", "[unit]") {
  Bench bench;
  bench.run_fixes(20);
  // Every joint at its speed limit at once: the swing alone moves the tip at some 2 m/s.
  for (int j = 0; j < bench.q.size(); ++j) bench.v[j] = 0.9 * bench.model->joints()[static_cast<std::size_t>(j)].max_velocity;
  bench.run_fixes(50);
  CHECK_FALSE(bench.check->result().disagrees);
  CHECK(bench.check->judged() == 70);
  CHECK(bench.check->stale_count() == 0);
  CHECK(bench.check->peak_ratio() < 0.02);
}

TEST_CASE("machine tags: a tag 0.8 m from its prediction is found after exactly disagree_fixes fixes, naming it and its joints", "[unit]") {
  Bench bench;
  bench.run_fixes(5);
  bench.offset_m = Eigen::Vector3d(0.0, 0.8, 0.0);
  const std::int64_t first_us = bench.now_us + kFixEveryUs - bench.now_us % kFixEveryUs;
  CHECK(bench.run_fixes(3) == 3);
  CHECK_FALSE(bench.check->result().disagrees);
  CHECK(bench.run_fixes(1) == 1);
  const guidance::MachineTagResult& r = bench.check->result();
  REQUIRE(r.disagrees);
  CHECK(r.tag_id == kTipTag);
  // Three fixes apart after the first: 0.3 s at 10 Hz.
  CHECK(r.detected_us - first_us == 3 * kFixEveryUs);
  CHECK(r.residual_m == Approx(0.8).margin(1e-6));
  CHECK(r.threshold_m < 0.8);
  // The boom tip moves with the swing, the luffing and the telescope; not with the hoist rope.
  CHECK(r.joints_seen == 0b0111u);
  // Latched: good fixes do not clear it; reset() does.
  bench.offset_m.setZero();
  bench.run_fixes(5);
  CHECK(bench.check->result().disagrees);
  bench.check->reset();
  CHECK_FALSE(bench.check->result().disagrees);
  bench.run_fixes(10);
  CHECK_FALSE(bench.check->result().disagrees);
}

TEST_CASE("machine tags: the threshold holds quality, time offset and model allowance", "[unit]") {
  SECTION("an offset within it, at quality 2, is no finding") {
    Bench bench;
    bench.offset_m = Eigen::Vector3d(0.0, 0.0, 0.5);
    bench.run_fixes(30);
    CHECK_FALSE(bench.check->result().disagrees);
    CHECK(bench.check->peak_ratio() > 0.5);
  }
  SECTION("the same offset at quality 1 is one") {
    Bench bench;
    bench.quality = 1;
    bench.offset_m = Eigen::Vector3d(0.0, 0.0, 0.5);
    bench.run_fixes(30);
    CHECK(bench.check->result().disagrees);
  }
  SECTION("the threshold is 2 sigma, plus 35 ms at the tip's speed bound, plus 0.15 m") {
    Bench bench;
    bench.quality = 1;
    bench.offset_m = Eigen::Vector3d(0.0, 0.0, 0.5);
    bench.run_fixes(30);
    REQUIRE(bench.check->result().disagrees);
    // The oracle: each joint's lever on the tip, by a central difference, times its speed limit.
    double speed_m_s = 0.0;
    for (int j = 0; j < bench.q.size(); ++j) {
      planning::JointVector up = bench.q;
      planning::JointVector down = bench.q;
      up[j] += 1e-3;
      down[j] -= 1e-3;
      speed_m_s += (bench.truth(up) - bench.truth(down)).norm() / 2e-3 * bench.model->joints()[static_cast<std::size_t>(j)].max_velocity;
    }
    CHECK(speed_m_s > 1.0);
    CHECK(bench.check->result().threshold_m == Approx(2.0 * 0.1 + 0.035 * speed_m_s + 0.15).epsilon(1e-3));
  }
}

TEST_CASE("machine tags: a good fix between bad ones starts the count again", "[unit]") {
  Bench bench;
  for (int round = 0; round < 5; ++round) {
    bench.offset_m = Eigen::Vector3d(1.0, 0.0, 0.0);
    bench.run_fixes(3);
    bench.offset_m.setZero();
    bench.run_fixes(1);
  }
  CHECK_FALSE(bench.check->result().disagrees);
}

TEST_CASE("machine tags: fixes of unknown quality are not judged", "[unit]") {
  Bench bench;
  bench.quality = 15;
  bench.offset_m = Eigen::Vector3d(5.0, 0.0, 0.0);
  bench.run_fixes(20);
  CHECK_FALSE(bench.check->result().disagrees);
  CHECK(bench.check->judged() == 0);
  CHECK(bench.check->not_judged() == 20);
  // They still keep the tag fresh.
  CHECK(bench.check->stale_count() == 0);
}

TEST_CASE("machine tags: a stale tag is an alert, not a finding, and its count starts again", "[unit]") {
  Bench bench;
  bench.run_fixes(3);
  bench.offset_m = Eigen::Vector3d(1.0, 0.0, 0.0);
  bench.run_fixes(3);
  bench.fixing = false;
  // Stale once no fix came for more than 500 ms.
  for (int c = 0; c < 50; ++c) (void)bench.cycle();
  CHECK(bench.check->stale_count() == 0);
  for (int c = 0; c < 2; ++c) (void)bench.cycle();
  CHECK(bench.check->stale_count() == 1);
  CHECK(bench.check->stale_tag() == kTipTag);
  for (int c = 0; c < 200; ++c) (void)bench.cycle();
  CHECK_FALSE(bench.check->result().disagrees);
  // Back, still 1 m off: three fixes after the gap are not yet a finding, the fourth is.
  bench.fixing = true;
  bench.run_fixes(1);
  CHECK(bench.check->stale_count() == 0);
  bench.run_fixes(2);
  CHECK_FALSE(bench.check->result().disagrees);
  bench.run_fixes(1);
  CHECK(bench.check->result().disagrees);
}

TEST_CASE("machine tags: a tag never heard is stale after 500 ms", "[unit]") {
  Bench bench;
  bench.fixing = false;
  for (int c = 0; c < 50; ++c) (void)bench.cycle();
  CHECK(bench.check->stale_count() == 0);
  for (int c = 0; c < 2; ++c) (void)bench.cycle();
  CHECK(bench.check->stale_count() == 1);
}

TEST_CASE("machine tags: start-up refuses a mount the model does not have", "[unit]") {
  Bench bench;
  const planning::TagMount none = planning::resolve_tag_mount(*bench.model, "hook");
  CHECK(none.index == -1);
  const std::vector<MachineTag> bad{{9, none, Eigen::Vector3d::Zero()}};
  CHECK_THROWS_AS(MachineTagCheck(*bench.model, bad), std::invalid_argument);
  const planning::TagMount carrier = planning::resolve_tag_mount(*bench.model, "carrier");
  CHECK_FALSE(carrier.frame);
  CHECK(carrier.index == bench.model->body_index("carrier"));
}

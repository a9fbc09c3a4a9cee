// SPDX-License-Identifier: Apache-2.0
// Trajectory calculation and sampling run in the control cycle: they must not touch the heap.
#include <catch2/catch.hpp>

#include <array>
#include <memory>
#include <cmath>
#include <random>

#include "allocation_counter.hpp"
#include "mgc/guidance/diagnostics.hpp"
#include "mgc/guidance/online.hpp"
#include "mgc/guidance/trajectory.hpp"
#include "mgc/planning/io/scenario_loader.hpp"

using namespace mgc::guidance;

TEST_CASE("calculate_time_optimal and Profile::at_time do not allocate", "[unit]") {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Profile profile;
  double sink = 0.0;
  const long before = mgc::test::allocation_count();
  for (int n = 0; n < 10000; ++n) {
    const JointLimits limits{1.0 + u(rng) * 0.5, 2.0 + u(rng), 5.0 + u(rng)};
    const JointState start{u(rng), 3.0 * u(rng), 6.0 * u(rng)};
    const CalculationResult r = calculate_time_optimal(start, 5.0 * u(rng), limits, profile);
    sink += r.ok() ? profile.at_time(profile.duration() * 0.5).position : 0.0;
  }
  CHECK(mgc::test::allocation_count() == before);
  CHECK(std::isfinite(sink));
}

TEST_CASE("calculate_for_duration and calculate_synchronized do not allocate", "[unit]") {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::array<JointState, kMaxSynchronizedJoints> starts{};
  std::array<double, kMaxSynchronizedJoints> targets{};
  std::array<JointLimits, kMaxSynchronizedJoints> limits{};
  std::array<Profile, kMaxSynchronizedJoints> out{};
  double sink = 0.0;
  const long before = mgc::test::allocation_count();
  for (int n = 0; n < 2000; ++n) {
    for (std::size_t i = 0; i < kMaxSynchronizedJoints; ++i) {
      limits[i] = {1.0 + u(rng) * 0.5, 2.0 + u(rng), 5.0 + u(rng)};
      starts[i] = {u(rng), 3.0 * u(rng), 6.0 * u(rng)};
      targets[i] = 5.0 * u(rng);
    }
    const SynchronizedResult r = calculate_synchronized(starts.data(), targets.data(), limits.data(), 4, out.data());
    sink += r.ok() ? r.duration_s : 0.0;
    const CalculationResult d = calculate_for_duration(starts[5], targets[5], limits[5], 10.0 + u(rng), out[5]);
    sink += d.ok() ? out[5].duration() : 0.0;
  }
  CHECK(mgc::test::allocation_count() == before);
  CHECK(std::isfinite(sink));
}

TEST_CASE("the online trajectory and the one-joint-at-a-time wrapper do not allocate", "[unit]") {
  std::mt19937_64 rng(4);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  JointTrajectory online;
  OneJointAtATime joints;
  std::array<JointState, OneJointAtATime::kMaxJoints> current{}, next{};
  std::array<JointLimits, OneJointAtATime::kMaxJoints> limits{};
  JointState state{}, out{};
  const long before = mgc::test::allocation_count();
  for (int n = 0; n < 5000; ++n) {
    // A new target every 50 cycles, and a new selected joint: recalculations and latched holds.
    const double target = 3.0 * u(rng);
    const JointLimits lim{1.0 + 0.5 * u(rng), 2.0 + u(rng), 5.0 + u(rng)};
    for (int c = 0; c < 50; ++c) {
      (void)online.update(state, target, lim, 0.01, out);
      state = out;
      (void)joints.update(current.data(), limits.data(), current.size(), static_cast<std::size_t>(n) % current.size(),
                          target, 0.01, next.data());
      current = next;
    }
  }
  CHECK(mgc::test::allocation_count() == before);
  CHECK(std::isfinite(state.position + current[0].position));
}

TEST_CASE("the plausibility monitor's cycle, its findings and its reset do not allocate", "[unit]") {
  const std::array<PlausibilityJoint, 2> joints{{{0.05, 0.02, 0.0, 1.4, false, false}, {0.4, 0.2, 1.0, 36.0, false, true}}};
  PlausibilityMonitor monitor(joints);
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  PlausibilityInputs in;
  in.drive_enabled = true;
  in.valve_active = true;
  in.position = {0.7, 10.0};
  int findings = 0;
  const long before = mgc::test::allocation_count();
  for (int n = 0; n < 20000; ++n) {
    in.now_us += 10'000;
    for (std::size_t j = 0; j < 2; ++j) {
      in.commanded_velocity[j] = 0.5 * joints[j].max_velocity * u(rng);
      in.position[j] += in.commanded_velocity[j] * 0.01 + (n % 997 == 0 ? 0.3 : 0.0);  // now and then a lie
      in.valid[j] = n % 301 != 0;
      in.updated[j] = true;
      in.valve_commanded[j] = in.commanded_velocity[j] / joints[j].max_velocity;
      in.valve_applied[j] = in.valve_commanded[j];
    }
    ++in.valve_command_counter;
    ++in.valve_commands_sent;
    if (monitor.update(in).fault != PlausibilityFault::None) {
      ++findings;
      monitor.reset();
    }
  }
  CHECK(mgc::test::allocation_count() == before);
  CHECK(findings > 0);
}

TEST_CASE("MachineTagCheck::update does not allocate", "[unit]") {
  const mgc::planning::Scenario scenario =
      mgc::planning::io::load_scenario(std::string(MGC_SOURCE_DIR) + "/scenarios/thesis-steel-frame.yaml");
  const auto model = mgc::planning::build_model(scenario);
  const std::array<MachineTag, 2> tags{MachineTag{200, mgc::planning::resolve_tag_mount(*model, "boom_tip"), Eigen::Vector3d::Zero()},
                                       MachineTag{201, mgc::planning::resolve_tag_mount(*model, "superstructure"), Eigen::Vector3d::Zero()}};
  MachineTagCheck check(*model, tags);
  std::array<MachineTagFix, 3> fixes{};
  fixes[0].id = 200;
  fixes[1].id = 201;
  fixes[2].id = 5;
  MachineTagInputs in;
  in.joints_valid = true;
  for (int j = 0; j < model->dof(); ++j) in.position[static_cast<std::size_t>(j)] = scenario.start[j];
  in.fixes = fixes;
  const long before = mgc::test::allocation_count();
  for (int c = 1; c <= 2000; ++c) {
    in.now_us = c * 10'000;
    in.joints_t_us = in.now_us;
    in.position[0] += 1e-4;
    for (std::size_t k = 0; k < fixes.size(); ++k) {
      fixes[k].updated = c % 10 == static_cast<int>(k);
      fixes[k].t_us = in.now_us;
      fixes[k].quality = c % 100 < 90 ? 2 : 15;
      fixes[k].position_m = {static_cast<double>(c % 7), 1.0, 2.0};  // off from the model: the counts run
    }
    (void)check.update(in);
    if (check.result().disagrees) check.reset();
  }
  CHECK(mgc::test::allocation_count() == before);
  CHECK(check.judged() > 100);
}

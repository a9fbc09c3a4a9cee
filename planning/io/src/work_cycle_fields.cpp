// SPDX-License-Identifier: Apache-2.0
#include "work_cycle_fields.hpp"

#include <cmath>
#include <numbers>
#include <sstream>
#include <string>

#include "mgc/planning/excavator.hpp"

namespace mgc::planning::io {
namespace {

constexpr double kDegToRad = std::numbers::pi / 180.0;
// The planner's tolerance for a held value (NonUniformRrtPlanner). [rad]
constexpr double kHoldTolerance_rad = 1e-9;

std::string deg_text(double angle_rad) {
  std::ostringstream s;
  s << angle_rad / kDegToRad;
  return s.str();
}

// One joint value of the dump, in degrees in the file, checked against the joint's range.
double read_joint_deg(const Value& value, const MachineDefinition& machine, int joint) {
  const JointSpec& j = machine.joints[static_cast<std::size_t>(joint)];
  const double angle_rad = value.angle_deg() * kDegToRad;
  if (angle_rad < j.position_min - 1e-12 || angle_rad > j.position_max + 1e-12) {
    value.fail("a value within the joint range [" + deg_text(j.position_min) + ", " + deg_text(j.position_max) +
               "] deg of " + machine.file);
  }
  return angle_rad;
}

}  // namespace

WorkCycleSpec read_work_cycle(const Value& value, const Scenario& scenario, const Value& goal,
                              const std::function<JointVector(const Value&)>& read_configuration) {
  const MachineDefinition& machine = scenario.machine;
  if (machine.kind != MachineKind::Excavator) {
    value.fail_plain(std::string("a work cycle (dig, dump, return) is an excavator's; ") + machine.file + " is a " +
                     to_string(machine.kind));
  }
  Fields f = value.fields();

  // Move-to-dump carries the soil: the goal keeps the start's bucket ground angle.
  const double carry_rad = bucket_ground_angle_rad(scenario.start);
  if (std::abs(wrap_angle(bucket_ground_angle_rad(scenario.goal) - carry_rad)) > kHoldTolerance_rad) {
    Fields goal_fields = goal.fields();
    const double held_bucket_rad = carry_rad - scenario.goal[Excavator::kBoom] - scenario.goal[Excavator::kArm];
    goal_fields.required("bucket_deg")
        .fail(deg_text(held_bucket_rad) + ", which keeps the start's bucket ground angle (boom + arm + bucket = " +
              deg_text(carry_rad) + " deg) for the work cycle's move-to-dump");
  }

  // Dumping: swing and boom stay at the goal's, the arm and the bucket move.
  WorkCycleSpec cycle;
  const Value dump = f.required("dump");
  Fields d = dump.fields();
  cycle.dumped = scenario.goal;
  cycle.dumped[Excavator::kArm] = read_joint_deg(d.required("arm_deg"), machine, Excavator::kArm);
  const Value bucket = d.required("bucket_deg");
  cycle.dumped[Excavator::kBucket] = read_joint_deg(bucket, machine, Excavator::kBucket);
  d.finish();
  // Angles grow upwards, so curling the bucket out to empty it raises its ground angle.
  const double dumped_rad = bucket_ground_angle_rad(cycle.dumped);
  if (!(dumped_rad > carry_rad)) {
    bucket.fail("a bucket curled out from the carry: boom + arm + bucket above the carry's " + deg_text(carry_rad) +
                " deg (here " + deg_text(dumped_rad) + " deg)");
  }
  cycle.dumped_ref = {scenario.file, dump.line(), "work_cycle.dump"};

  if (auto next = f.optional("next_dig")) {
    cycle.next_dig = read_configuration(*next);
    cycle.next_dig_ref = {scenario.file, next->line(), "work_cycle.next_dig"};
  } else {
    // Back to the same dig; an empty reference says the start stands in for it.
    cycle.next_dig = scenario.start;
  }
  f.finish();
  return cycle;
}

}  // namespace mgc::planning::io

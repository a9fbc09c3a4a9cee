// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <ostream>
#include <string>
#include <vector>

#include "planning_bench.hpp"

namespace mgc::bench {

//! Re-planning on the event scenarios: seed 000's Table 5 (DRRT against
//! DRRT-Con-Con-Mod: time per re-planning event, successes) and the thesis's Table 4.3 (DRRT
//! re-planning on the hydraulic and tower cranes), each lift run with the kinematic execution of
//! execute_with_replanning for every seed at several phases of the intrusion, plus the excavator
//! whose path a truck parks on.
//! One lift, or one re-planning event of a lift (event < 0: a lift without any).
struct ReplanRow {
  std::string scenario;
  std::string replanner;
  std::uint64_t seed = 0;
  double start_time_s = 0.0;
  std::string outcome;
  int contact_states = 0;
  double first_plan_ms = 0.0;
  int event = -1;
  double event_t_s = 0.0;
  std::string status;
  double repair_ms = 0.0;
  //! Choosing the way out of the prediction before the repair (0 when the machine was not inside
  //! it), and the time it then moved out: back along its motion (escape_joint -1) or one joint.
  double escape_ms = 0.0;
  double retreat_s = 0.0;
  int escape_joint = -1;
  //! RepairEvent's: the prediction still over the machine after its retreat, and an obstacle at
  //! its present pose on the machine where it stopped.
  bool predicted_start_conflict = false;
  bool start_in_contact = false;
  int iterations = 0;
  int invalidated_nodes = 0;
  int bridge_attempts = 0;
  int path_nodes = 0;
};

struct ReplanTables {
  std::string markdown;
  std::vector<ReplanRow> rows;
  bool targets_met = false;
};

//! replan.csv's lines and replan.json's "events" array.
void write_replan_csv(std::ostream& out, const std::vector<ReplanRow>& rows);
void write_replan_json(tools::JsonWriter& w, const std::vector<ReplanRow>& rows);

[[nodiscard]] ReplanTables run_replanning_tables(const PlanningBenchOptions& options, int runs);

//! The `replan` suite: the tables above alone; writes replan.md, replan.csv and replan.json.
int run_replan_suite(const PlanningBenchOptions& options, const std::string& command);

}  // namespace mgc::bench

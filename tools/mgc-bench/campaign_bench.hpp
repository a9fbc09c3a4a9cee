// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <cstdint>
#include <limits>
#include <string>
#include <vector>

namespace mgc::bench {

//! Lifts 0 .. kShippedLifts - 1 run on the shipped sites, the lifts from kShippedLifts on on
//! generated sites (docs/sites.md), so that adding generated lifts leaves every shipped lift as it was.
inline constexpr int kShippedLifts = 1000;

//! Lifts on generated sites in a default campaign. [-]
inline constexpr int kGeneratedLifts = 500;

struct CampaignOptions {
  std::string scenarios_dir = "scenarios";  //!< folder of the shipped scenarios
  std::string out_dir;                      //!< campaign.md and campaign.csv go here when not empty
  //! Where the generated sites are written: when empty, <out_dir>/campaign-sites, or without an
  //! out_dir a folder in the system's temporary folder.
  std::string sites_dir;
  std::string command;                      //!< the command line, for the report
  int first_lift = 0;                       //!< lifts first_lift .. lifts - 1 run [-]
  int lifts = kShippedLifts + kGeneratedLifts;  //!< see first_lift [-]
  int lift = -1;                            //!< >= 0: run this lift alone and print its whole record
  std::uint64_t first_seed = 0;             //!< lift i draws everything from seed first_seed + 1 + i
  int threads = 2;                          //!< lifts run in parallel; the results do not depend on it
  bool progress = true;                     //!< a progress bar on stderr
};

//! What one lift is disturbed by: at most one thing.
enum class Disturbance : std::uint8_t {
  None,    //!< the lift alone (UWB noise and dropouts always on)
  Crane,   //!< the site's other crane swings in at a random time, direction and speed
  Truck,   //!< a truck drives in and parks clear of the lift's start and goal
  Worker,  //!< a worker carrying a tag walks across the site
  Fault,   //!< a sensing or bus fault from mgc-sim's list at a random time during motion
};

[[nodiscard]] const char* to_string(Disturbance d) noexcept;

//! One run of a lift on the stepped rig (the disturbed lift or its undisturbed twin), measured in
//! the true state.
struct LiftRun {
  bool completed = false;            //!< the supervisor reached the goal (GoalReached)
  std::string state;                 //!< supervisor state at the end
  std::string reason;                //!< its reason
  double end_s = 0.0;                //!< simulation time at the end [s]
  double lift_s = std::numeric_limits<double>::quiet_NaN();  //!< goal request accepted -> goal reached [s]
  double motion_start_s = std::numeric_limits<double>::quiet_NaN();  //!< EXECUTING first entered [s]
  int safety_stops = 0;              //!< ControllerStats::safety_stops
  int stops = 0;                     //!< transitions into STOPPING or FAULT after the goal request, any reason
  int replans = 0;
  int approach_warnings = 0;
  //! The first stop or fault after the goal request: when, why, the value it named. [s]
  double first_stop_s = std::numeric_limits<double>::quiet_NaN();
  std::string first_stop_reason;
  int first_stop_value = -1;
  //! Least true clearances over the run: to everything, to the static site, to the dynamic
  //! obstacles; the load's bottom above the ground (NaN without a hung load); peak chart
  //! utilisation (NaN without a chart). [m, -]
  double least_clearance_m = std::numeric_limits<double>::infinity();
  double least_static_m = std::numeric_limits<double>::infinity();
  double least_dynamic_m = std::numeric_limits<double>::infinity();
  double least_ground_m = std::numeric_limits<double>::quiet_NaN();
  double peak_chart = std::numeric_limits<double>::quiet_NaN();
  std::uint64_t samples_chart_exceeded = 0;
  std::uint64_t samples_below_ground = 0;
  std::uint64_t samples = 0;
  //! The first contact (true clearance under 1 mm): when, with what (the obstacle and the
  //! machine's body), and whether the machine was at rest and the obstacle moving then. [s]
  double contact_s = std::numeric_limits<double>::quiet_NaN();
  std::string contact_with;
  bool contact_machine_at_rest = false;
  bool contact_intruder_moving = false;
  //! The approach warning's lead before that contact: contact time - since when it had been on
  //! (gaps under 1 s bridged); NaN when it was not on within the second before. [s]
  double approach_lead_s = std::numeric_limits<double>::quiet_NaN();
  //! How long the intruder had been moving without a pause at that contact: no warning can come
  //! earlier than its start of motion. NaN for a contact with a standing obstacle. [s]
  double intruder_moving_for_s = std::numeric_limits<double>::quiet_NaN();
  //! From the injected fault to the true machine at rest (every joint under 1e-4 rad/s or m/s). [s]
  double rest_after_fault_s = std::numeric_limits<double>::quiet_NaN();
  std::string transitions;           //!< "t s STATE (Reason value); ..."
  double wall_s = 0.0;               //!< not in the record (it differs between runs)
};

//! A lift drawn from its seed and how it ended, beside its undisturbed twin.
struct LiftRecord {
  int index = 0;
  std::uint64_t seed = 0;
  std::string site;                  //!< scenario file name
  //! A generated site's family (empty on a shipped site), its site seed, and how many sites were
  //! drawn before it and could not be set up (generate_site found no draw, or no feasible goal).
  std::string family;
  std::uint64_t site_seed = 0;
  int site_redraws = 0;
  std::vector<double> goal;          //!< the drawn goal [rad | m]
  int goal_draws = 0;                //!< goals drawn until one was feasible (0: the scenario's own)
  Disturbance disturbance = Disturbance::None;
  std::string what;                  //!< the disturbance in words, with its numbers
  std::string fault_text;            //!< mgc-sim's fault text, for a fault
  double fault_s = std::numeric_limits<double>::quiet_NaN();  //!< the fault's start [s]
  //! The fault's documented finding (docs/diagnostics.md, docs/protocol.md): the reasons that name
  //! it, the value they must name (-2: any) and the time within which it must come. A tag-noise
  //! fault has none (the tracker's gate must absorb it). [s]
  std::vector<std::string> expected_reasons;
  int expected_value = -2;
  double detect_budget_s = std::numeric_limits<double>::quiet_NaN();
  double detect_s = std::numeric_limits<double>::quiet_NaN();  //!< fault -> the finding naming it [s]
  bool detected = false;
  LiftRun run;                       //!< the lift as disturbed (the twin itself for Disturbance::None)
  LiftRun twin;                      //!< the same lift undisturbed
};

//! Runs lift `index` (its twin first, then the lift disturbed). Throws std::runtime_error when a
//! scenario cannot be loaded or a run cannot be set up, or when none of a generated lift's site
//! draws could be set up.
[[nodiscard]] LiftRecord run_campaign_lift(const CampaignOptions& options, int index);

//! The lift's whole record, as --lift N prints it: every figure measured, no wall time, so that
//! the same lift gives the same text.
[[nodiscard]] std::string lift_record_text(const LiftRecord& record);

//! The folder generated sites are written to (CampaignOptions::sites_dir).
[[nodiscard]] std::string campaign_sites_dir(const CampaignOptions& options);

//! Lifts options.first_lift .. options.lifts - 1 on options.threads threads, in index order.
[[nodiscard]] std::vector<LiftRecord> run_campaign(const CampaignOptions& options);

//! The `campaign` suite (docs/safety.md "The campaign"): the lifts, the targets met or not, a
//! markdown report on stdout and campaign.md / campaign.csv in out_dir. With options.lift >= 0,
//! that lift's record alone. Returns the process exit code.
int run_campaign_suite(const CampaignOptions& options);

}  // namespace mgc::bench

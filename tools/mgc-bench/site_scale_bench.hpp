// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace mgc::bench {

struct SiteScaleOptions {
  std::string scenarios_dir = "scenarios";
  //! site-scale.md, .csv and .json go here, and the generated site files under its sites/; when
  //! empty, the site files go to a folder of the system's temporary folder, named on stderr.
  std::string out_dir;
  std::string command;  //!< the command line, recorded in site-scale.json
  std::vector<int> machines = {2, 4, 8, 16};
  double sim_s = 60.0;     //!< simulated time of each run [s]
  std::uint64_t seed = 0;  //!< the generated sites' seed
};

//! The `site-scale` suite (docs/site.md, "Scale"): a lone TMS870 (the baseline), then the
//! generated site of each size on the site rig in stepped time for sim_s, every lift requested at
//! 0 s. Per size: each member's Controller::step wall clock (p50, p95, p99), the TMS870 members'
//! beside the lone one's and the difference per other machine, the checks of the delivered
//! messages (SiteVerifier, per message) and the site rules (decide_site() again on the same
//! inputs) timed apart, the messages and bytes each machine and the site send per second, the
//! cycles from a new plan's delivery to the receivers' prediction taking it up, and the outcomes
//! (lifts done, least true clearance between machines, referee samples in contact). Returns the
//! exit code (0 once it ran); a generated site that does not load throws planning::io::InputError.
int run_site_scale_suite(const SiteScaleOptions& options);

}  // namespace mgc::bench

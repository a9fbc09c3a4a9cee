// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <string>

namespace mgc::bench {

struct SiteBenchOptions {
  std::string scenarios_dir = "scenarios";
  std::string out_dir;  //!< site.csv, site.json and site.md go here when not empty
  std::string command;  //!< the command line, recorded in site.json
  int first_offset_s = 0;   //!< the sweep's first start offset of the tower crane's lift [s]
  int last_offset_s = 16;   //!< its last [s]
  double limit_s = 300.0;   //!< simulated time a run may take before it counts as not done [s]
};

//! The `site` suite (docs/site.md, "Measured"): crossing-cranes.yaml's two cranes in stepped time
//! on the site rig (mgc_site_rig), the tower crane's lift started at each offset of the sweep after
//! the TMS870's; per offset whether each lift completed, its time against the machine alone, the
//! least true clearance between the machines, the re-plans and the site's stops. Returns the exit
//! code (0 once it ran: lifts not done are in its table); a site file that does not load throws
//! planning::io::InputError.
int run_site_suite(const SiteBenchOptions& options);

}  // namespace mgc::bench

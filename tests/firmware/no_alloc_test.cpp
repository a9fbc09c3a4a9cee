// SPDX-License-Identifier: Apache-2.0
// The estimation runs inside the control cycle: no heap allocation after construction.
#include <catch2/catch.hpp>


#include "allocation_counter.hpp"
#include "mgc/firmware/cyclic_executive.hpp"
#include "mgc/firmware/obstacle_tracker.hpp"
#include "../sim/sim_rig.hpp"

using namespace mgc;

TEST_CASE("the executive and the obstacle tracker do not allocate, outliers and loss included", "[unit][firmware]") {
  sim::SimConfig c;
  c.scenario_time_offset_s = 58.0;
  c.faults.push_back(sim::parse_fault("tag-noise:2@1+2,sigma_m=3", std::vector<std::string>{}));
  c.faults.push_back(sim::parse_fault("uwb-silent@3.5+1.5", std::vector<std::string>{}));
  test::SimRig rig("thesis-steel-frame.yaml", c, "fw-alloc");
  firmware::ObstacleTracker tracker(rig.scenario.dynamic_obstacles[0], {});
  firmware::SteppedClock clock;
  firmware::CyclicExecutive loop(clock, {10'000, 3});
  rig.on_cycle = [&](const hal::SensorSnapshot& s) {
    (void)loop.wait_next();
    (void)tracker.update(s, s.t_us);
    clock.advance_us(s.t_us % 70'000 == 0 ? 12'000 : 300);  // now and then an overrun
    loop.end_cycle();
  };
  rig.start();
  rig.run(500'000);
  const long before = test::allocation_count();
  rig.run(6'000'000);
  CHECK(test::allocation_count() == before);
  CHECK(tracker.counters().outliers > 0);
  CHECK(tracker.valid(rig.t_us));
  CHECK(loop.stats().deadline_misses > 0);
}

// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <Eigen/Geometry>

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "mgc/planning/machine_model.hpp"
#include "mgc/planning/scenario.hpp"

//! The coordinated site (docs/site.md): several machines, each guided by its own controller, on one
//! static site. The site file (docs/scenario-format.md, "Site file") reads into these structs.
namespace mgc::planning {

//! Machines on one site: the capacity of every fixed table the site channel keeps per machine.
inline constexpr std::size_t kMaxSiteMachines = 16;

//! How a machine's controller reaches its machine's CAN bus.
struct SiteBus {
  enum class Kind : std::uint8_t { Udp, SocketCan };
  Kind kind = Kind::Udp;
  int machine_port = 0;     //!< Udp: the machine's end (mgc-sim listens here) on 127.0.0.1
  int controller_port = 0;  //!< Udp: the controller's end (mgc listens here) on 127.0.0.1
  std::string interface;    //!< SocketCan: the interface name, e.g. vcan1
  SourceRef ref;

  //! The controller's --bus URL (docs/protocol.md): udp:127.0.0.1:C,peer=127.0.0.1:M or socketcan:IF.
  [[nodiscard]] std::string controller_url() const;
  //! The machine's (mgc-sim's) --bus URL: udp:127.0.0.1:M,peer=127.0.0.1:C or socketcan:IF.
  [[nodiscard]] std::string machine_url() const;
};

//! One lift in a machine's queue: start and goal as a scenario writes them, and the load (cranes).
struct SiteLift {
  std::string name;
  std::optional<TaskSpec> task;  //!< cranes
  JointVector start;
  JointVector goal;
  SourceRef start_ref;
  SourceRef goal_ref;
};

struct SiteMachine {
  std::int32_t id = 0;        //!< the machine's id on the site channel, unique, > 0
  std::int32_t priority = 0;  //!< 1 is the highest, a smaller number wins; unique on the site
  MachineDefinition machine;
  Eigen::Isometry3d world_from_base = Eigen::Isometry3d::Identity();
  SiteBus bus;
  //! The site's UWB tags fixed to this machine, where each sits (site_tag_mount_problem()); may be
  //! empty. They pose it while its messages are stale (docs/site.md, "Staleness").
  std::vector<MachineTagSpec> uwb_tags;
  std::vector<SiteLift> lifts;   //!< in the order the machine performs them
  SourceRef ref;                 //!< the machine's entry in `machines`
  SourceRef base_ref;            //!< its `base`
};

struct Site {
  std::string file;
  std::string name;
  std::string description;
  std::optional<std::string> key_file;  //!< the site key, resolved against the site's folder
  std::vector<StaticObstacle> obstacles;
  PlannerParams planner;
  std::vector<SiteMachine> machines;
  SourceRef machines_ref;  //!< the `machines` field
};

//! The machine's footprint on the ground at its base pose, the part that never moves: the carrier
//! of a mobile crane, the mast of a tower crane, the undercarriage of an excavator. Corners in the
//! world xy plane, counter-clockwise. [m]
[[nodiscard]] std::array<Eigen::Vector2d, 4> base_footprint(const MachineDefinition& machine,
                                                            const Eigen::Isometry3d& world_from_base) noexcept;

//! Whether two convex quadrilaterals (base_footprint()) overlap, touching included.
[[nodiscard]] bool footprints_overlap(const std::array<Eigen::Vector2d, 4>& a, const std::array<Eigen::Vector2d, 4>& b) noexcept;

//! One lift of one machine as a scenario: the machine, its base, the lift's task, start and goal,
//! the site's static obstacles and planner parameters, no dynamic obstacles (the other machines
//! come over the site channel). The name is "<site>/<machine id>/<lift name>".
[[nodiscard]] Scenario lift_scenario(const Site& site, std::size_t machine, std::size_t lift);

//! An upper bound on the speed of any point of the machine: the sum over joints of
//! displacement_bound() times the joint's maximum velocity. A machine not heard from for age_s is
//! within this speed times age_s of where it was last seen. [m/s]
[[nodiscard]] double max_point_speed_m_s(const MachineModel& model) noexcept;

}  // namespace mgc::planning

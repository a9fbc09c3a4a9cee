// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <Eigen/Geometry>

#include <cstddef>
#include <string>
#include <string_view>

#include "mgc/planning/machine_model.hpp"

//! UWB tags fixed to the machine itself (docs/scenario-format.md `machine_tags`): where on a machine
//! a tag may sit, and where forward kinematics puts it. A tag sits on a body or a kinematic frame
//! that the joints pose rigidly; the hoist rope, hook, sling, load and a dual lift's girder swing on
//! their ropes, and a telescopic boom changes its length, so none of them carries a tag.
namespace mgc::planning {

//! Most tags one machine carries: the check that compares them with the encoders has fixed capacity.
inline constexpr std::size_t kMaxMachineTags = 8;
//! A tag sits within this distance of its mount's origin: a machine is smaller, and a larger
//! offset is a site coordinate written by mistake. [m]
inline constexpr double kMaxMachineTagOffset_m = 100.0;

//! A tag's mount resolved against a model: a body or a frame, by index.
struct TagMount {
  bool frame = false;  //!< index names a frame (MachineModel::frame_names()), else a body
  int index = -1;
};

//! Empty when a machine of this kind (a dual lift when dual_crane) carries tags on `name`;
//! otherwise what was expected, naming the accepted mounts. Start-up only.
[[nodiscard]] std::string tag_mount_problem(MachineKind kind, bool dual_crane, std::string_view name);

//! The mount `name` on the model; index -1 when the model has no such rigid body or frame.
//! Start-up only.
[[nodiscard]] TagMount resolve_tag_mount(const MachineModel& model, std::string_view name);

//! A tag of the site's RTLS on a machine of a coordinated site (the site file's `uwb_tags`), which
//! poses that machine while its own messages are stale: every mount tag_mount_problem() accepts,
//! and on a crane also the frame `hook`, which the model hangs plumb below the boom tip or trolley
//! (a tag there sees the hoist; its sway shows in the fit's residual). Empty when accepted,
//! otherwise what was expected. Start-up only.
[[nodiscard]] std::string site_tag_mount_problem(MachineKind kind, bool dual_crane, std::string_view name);

//! The mount `name` as site_tag_mount_problem() accepts it; index -1 when the model has none.
//! Start-up only.
[[nodiscard]] TagMount resolve_site_tag_mount(const MachineModel& model, std::string_view name);

//! World position of a tag at local_m in its mount, from a forward kinematics result. RT-safe.
[[nodiscard]] inline Eigen::Vector3d tag_position(const Kinematics& k, const TagMount& mount,
                                                  const Eigen::Vector3d& local_m) noexcept {
  const auto i = static_cast<std::size_t>(mount.index);
  return mount.frame ? Eigen::Vector3d(k.frames[i] * local_m) : Eigen::Vector3d(k.bodies[i].world_from_body * local_m);
}

}  // namespace mgc::planning

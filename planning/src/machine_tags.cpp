// SPDX-License-Identifier: Apache-2.0
#include "mgc/planning/machine_tags.hpp"

#include <algorithm>
#include <array>
#include <string>

namespace mgc::planning {
namespace {

struct Mount {
  std::string_view name;
  bool frame;
};

// Per machine, the bodies and frames the joints pose rigidly. Left out on purpose: the base frame
// (it says nothing the carrier does not), a mobile crane's telescopic boom body (its centre moves as
// it extends: a tag on the tip section names the frame boom_tip), and everything that hangs on a
// rope (cable, hook, sling, load, the girder).
constexpr std::array kMobileCrane{Mount{"carrier", false}, Mount{"superstructure", false}, Mount{"swing", true},
                                  Mount{"boom_foot", true}, Mount{"boom_tip", true}};
constexpr std::array kTowerCrane{Mount{"mast", false}, Mount{"jib", false}, Mount{"counter_jib", false}, Mount{"slew", true},
                                 Mount{"trolley", true}};
constexpr std::array kExcavator{Mount{"undercarriage", false}, Mount{"house", false},    Mount{"cab", false},
                                Mount{"boom", false},          Mount{"arm", false},      Mount{"bucket", false},
                                Mount{"swing", true},          Mount{"boom_foot", true}, Mount{"arm_pin", true},
                                Mount{"bucket_pin", true},     Mount{"bucket_tip", true}};
// The dual lift's booms have a fixed length (DualCraneSpec), so their boxes carry tags.
constexpr std::array kDualCrane{Mount{"carrier_1", false},      Mount{"superstructure_1", false}, Mount{"boom_1", false},
                                Mount{"boom_tip_1", true},      Mount{"carrier_2", false},        Mount{"superstructure_2", false},
                                Mount{"boom_2", false},         Mount{"boom_tip_2", true}};

std::span<const Mount> mounts(MachineKind kind, bool dual_crane) noexcept {
  if (dual_crane) return kDualCrane;
  switch (kind) {
    case MachineKind::MobileCrane: return kMobileCrane;
    case MachineKind::TowerCrane: return kTowerCrane;
    case MachineKind::Excavator: return kExcavator;
  }
  return {};
}

const Mount* find(MachineKind kind, bool dual_crane, std::string_view name) noexcept {
  for (const Mount& m : mounts(kind, dual_crane)) {
    if (m.name == name) return &m;
  }
  return nullptr;
}

}  // namespace

std::string tag_mount_problem(MachineKind kind, bool dual_crane, std::string_view name) {
  if (find(kind, dual_crane, name) != nullptr) return {};
  std::string text = "a body or frame the joints pose rigidly: one of ";
  bool first = true;
  for (const Mount& m : mounts(kind, dual_crane)) {
    if (!first) text += ", ";
    text += m.name;
    first = false;
  }
  if (kind == MachineKind::Excavator) return text;
  text += " (the rope, hook, sling and load swing";
  if (kind == MachineKind::MobileCrane && !dual_crane) text += "; the boom telescopes: name boom_tip or boom_foot";
  return text + ")";
}

TagMount resolve_tag_mount(const MachineModel& model, std::string_view name) {
  const Mount* m = find(model.kind(), model.bodies().size() > 0 && model.body_index("girder") >= 0, name);
  if (m == nullptr) return {};
  if (!m->frame) return {false, model.body_index(name)};
  const auto frames = model.frame_names();
  const auto it = std::find(frames.begin(), frames.end(), name);
  return {true, it == frames.end() ? -1 : static_cast<int>(it - frames.begin())};
}

namespace {

bool site_hook(MachineKind kind, bool dual_crane, std::string_view name) noexcept {
  return name == "hook" && !dual_crane && (kind == MachineKind::MobileCrane || kind == MachineKind::TowerCrane);
}

}  // namespace

std::string site_tag_mount_problem(MachineKind kind, bool dual_crane, std::string_view name) {
  if (site_hook(kind, dual_crane, name) || find(kind, dual_crane, name) != nullptr) return {};
  std::string text = "a body or frame the joints pose: one of ";
  for (const Mount& m : mounts(kind, dual_crane)) text += std::string(m.name) + ", ";
  if (site_hook(kind, dual_crane, "hook")) text += "hook, ";
  text.resize(text.size() - 2);
  return text;
}

TagMount resolve_site_tag_mount(const MachineModel& model, std::string_view name) {
  const bool dual = model.body_index("girder") >= 0;
  if (!site_hook(model.kind(), dual, name)) return resolve_tag_mount(model, name);
  const auto frames = model.frame_names();
  const auto it = std::find(frames.begin(), frames.end(), name);
  return {true, it == frames.end() ? -1 : static_cast<int>(it - frames.begin())};
}

}  // namespace mgc::planning

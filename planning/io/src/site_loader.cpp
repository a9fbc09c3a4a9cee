// SPDX-License-Identifier: Apache-2.0
#include "mgc/planning/io/site_loader.hpp"

#include <climits>
#include <map>
#include <new>
#include <set>
#include <string>

#include "mgc/planning/machine_tags.hpp"
#include "scenario_fields.hpp"
#include "yaml_fields.hpp"

namespace mgc::planning::io {
namespace {

constexpr double kDegToRad = 3.14159265358979323846 / 180.0;

// Linux interface names: at most IFNAMSIZ - 1 = 15 characters.
constexpr std::size_t kMaxInterfaceChars = 15;

std::string line_of(const SourceRef& ref) { return "line " + std::to_string(ref.line); }

// A relative path without control characters (a NUL would cut the path the system sees).
std::string path_text(const Value& v) {
  const std::string text = v.text();
  for (const char c : text) {
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) v.fail("a path without control characters");
  }
  return text;
}

struct BusOwners {
  std::map<int, SourceRef> ports;
  std::map<std::string, SourceRef> interfaces;
};

SiteBus read_bus(const Value& value, BusOwners& owners) {
  Fields f = value.fields();
  SiteBus bus;
  bus.ref = {value.file(), value.line(), value.path()};
  auto [key, v] = f.one_of({"udp_ports", "socketcan"});
  if (key == "udp_ports") {
    bus.kind = SiteBus::Kind::Udp;
    const auto items = v.list();
    if (items.size() != 2) v.fail("[machine port, controller port]");
    bus.machine_port = items[0].integer(1, 65535);
    bus.controller_port = items[1].integer(1, 65535);
    if (bus.machine_port == bus.controller_port) items[1].fail("a port other than the machine port");
    for (const Value& item : items) {
      const int port = item.integer(1, 65535);
      if (auto it = owners.ports.find(port); it != owners.ports.end()) {
        item.fail("a port no other machine uses (" + it->second.field + ", " + line_of(it->second) + ")");
      }
    }
    owners.ports[bus.machine_port] = {v.file(), v.line(), v.path()};
    owners.ports[bus.controller_port] = {v.file(), v.line(), v.path()};
  } else {
    bus.kind = SiteBus::Kind::SocketCan;
    bus.interface = v.text();
    if (bus.interface.size() > kMaxInterfaceChars) v.fail("an interface name of at most 15 characters");
    for (const char c : bus.interface) {
      const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' || c == '-' || c == '.';
      if (!ok) v.fail("an interface name of letters, digits, '_', '-' and '.'");
    }
    if (auto it = owners.interfaces.find(bus.interface); it != owners.interfaces.end()) {
      v.fail("an interface no other machine uses (" + it->second.field + ", " + line_of(it->second) + ")");
    }
    owners.interfaces[bus.interface] = {v.file(), v.line(), v.path()};
  }
  f.finish();
  return bus;
}

//! Whether two tasks lift the same load on the same rigging under the same rule.
bool same_task(const TaskSpec& a, const TaskSpec& b) noexcept {
  return a.load_lb == b.load_lb && a.capacity_reduction_pct == b.capacity_reduction_pct && a.outriggers == b.outriggers &&
         a.counterweight_lb == b.counterweight_lb && a.constraint == b.constraint && a.load_size_m == b.load_size_m &&
         a.sling_length_m == b.sling_length_m;
}

//! first: the machine's first lift, null when this is it.
SiteLift read_lift(const Value& value, const MachineDefinition& machine, std::set<std::string>& names, const SiteLift* first) {
  Fields f = value.fields();
  SiteLift l;
  const Value name = f.required("name");
  l.name = name.name();
  if (!names.insert(l.name).second) name.fail("a lift name not used by another lift of this machine");
  if (machine.kind == MachineKind::Excavator) {
    if (auto task = f.optional("task")) task->fail_plain("an excavator's lift has no task (no load is lifted)");
  } else {
    const Value task = f.required("task");
    l.task = read_task_field(task, machine);
    // The controller, the simulator and the other members model a machine with its first lift's
    // load and rigging throughout: a later lift that names another would be run with the wrong one.
    if (first != nullptr && first->task && l.task && !same_task(*first->task, *l.task)) {
      task.fail_plain("differs from the machine's first lift's task; every lift of a machine is modelled with the first "
                      "lift's load, rigging, rule, load size and sling (docs/site.md, \"The load between lifts\")");
    }
  }
  const Value start = f.required("start");
  l.start = read_configuration_field(start, machine);
  l.start_ref = {value.file(), start.line(), start.path()};
  const Value goal = f.required("goal");
  l.goal = read_configuration_field(goal, machine);
  l.goal_ref = {value.file(), goal.line(), goal.path()};
  f.finish();
  return l;
}

struct SiteOwners {
  std::map<std::int32_t, SourceRef> ids;
  std::map<std::int32_t, SourceRef> priorities;
  std::map<int, SourceRef> tags;
  BusOwners bus;
};

SiteMachine read_machine_entry(const Value& value, const std::filesystem::path& folder, SiteOwners& owners) {
  Fields f = value.fields();
  SiteMachine m;
  m.ref = {value.file(), value.line(), value.path()};
  const Value id = f.required("id");
  m.id = id.integer(1, INT_MAX);
  if (auto it = owners.ids.find(m.id); it != owners.ids.end()) {
    id.fail("an id no other machine has (" + it->second.field + ", " + line_of(it->second) + ")");
  }
  owners.ids[m.id] = {id.file(), id.line(), id.path()};
  m.machine = read_machine_field(f.required("machine"), folder, "site");
  const Value base_value = f.required("base");
  m.base_ref = {base_value.file(), base_value.line(), base_value.path()};
  Fields base = base_value.fields();
  m.world_from_base = Eigen::Isometry3d::Identity();
  m.world_from_base.translate(base.required("position_m").position_m());
  m.world_from_base.rotate(Eigen::AngleAxisd(base.required("yaw_deg").angle_deg() * kDegToRad, Eigen::Vector3d::UnitZ()));
  base.finish();
  const Value priority = f.required("priority");
  m.priority = priority.integer(1, static_cast<int>(kMaxSiteMachines));
  if (auto it = owners.priorities.find(m.priority); it != owners.priorities.end()) {
    priority.fail("a priority no other machine has (" + it->second.field + ", " + line_of(it->second) + ")");
  }
  owners.priorities[m.priority] = {priority.file(), priority.line(), priority.path()};
  m.bus = read_bus(f.required("bus"), owners.bus);
  if (auto tags = f.optional("uwb_tags")) {
    for (const Value& tag : tags->list()) {
      if (m.uwb_tags.size() == kMaxMachineTags) tag.fail_plain("at most " + std::to_string(kMaxMachineTags) + " tags on one machine");
      Fields tf = tag.fields();
      MachineTagSpec t;
      const Value tag_id = tf.required("id");
      t.id = tag_id.integer(0, 255);
      if (auto it = owners.tags.find(t.id); it != owners.tags.end()) {
        tag_id.fail("a tag id no other tag has (" + it->second.field + ", " + line_of(it->second) + ")");
      }
      owners.tags[t.id] = {tag_id.file(), tag_id.line(), tag_id.path()};
      const Value body = tf.required("body");
      t.body = body.name();
      if (const std::string problem = site_tag_mount_problem(m.machine.kind, false, t.body); !problem.empty()) body.fail(problem);
      t.ref = {body.file(), body.line(), body.path()};
      const Value position = tf.required("position_m");
      t.position_m = position.position_m();
      if (!(t.position_m.norm() <= kMaxMachineTagOffset_m)) {
        position.fail("a position within 100 m of the body's origin");
      }
      tf.finish();
      m.uwb_tags.push_back(std::move(t));
    }
  }
  const Value lifts = f.required("lifts");
  const auto items = lifts.non_empty_list();
  if (items.size() > kMaxSiteLifts) lifts.fail("at most " + std::to_string(kMaxSiteLifts) + " lifts");
  std::set<std::string> names;
  for (const Value& item : items) m.lifts.push_back(read_lift(item, m.machine, names, m.lifts.empty() ? nullptr : &m.lifts.front()));
  f.finish();
  return m;
}

Site read_site(const std::filesystem::path& path) {
  const std::string file = path.string();
  const YAML::Node root = load_yaml(file);
  const Value root_value(root, "", &file, 1);
  Fields f = root_value.fields();
  Site site;
  site.file = file;
  site.name = f.required("name").name();
  if (auto d = f.optional("description")) site.description = d->text();
  if (auto key = f.optional("site_key_file")) site.key_file = (path.parent_path() / path_text(*key)).string();
  read_static_obstacles(f.required("obstacles"), site.obstacles);
  if (auto planner = f.optional("planner")) site.planner = read_planner_field(*planner);

  const Value machines = f.required("machines");
  site.machines_ref = {file, machines.line(), machines.path()};
  const auto items = machines.non_empty_list();
  if (items.size() > kMaxSiteMachines) machines.fail("at most " + std::to_string(kMaxSiteMachines) + " machines");
  SiteOwners owners;
  std::vector<std::array<Eigen::Vector2d, 4>> footprints;
  for (const Value& item : items) {
    SiteMachine m = read_machine_entry(item, path.parent_path(), owners);
    const auto footprint = base_footprint(m.machine, m.world_from_base);
    for (std::size_t k = 0; k < footprints.size(); ++k) {
      if (footprints_overlap(footprint, footprints[k])) {
        const SiteMachine& other = site.machines[k];
        throw InputError(m.base_ref.file, m.base_ref.line, m.base_ref.field,
                         "machine " + std::to_string(m.id) + "'s base footprint overlaps machine " + std::to_string(other.id) +
                             "'s (" + other.base_ref.field + ", " + line_of(other.base_ref) +
                             "); expected carriers, masts and undercarriages that stand apart");
      }
    }
    footprints.push_back(footprint);
    site.machines.push_back(std::move(m));
  }
  f.finish();
  return site;
}

}  // namespace

Site load_site(const std::filesystem::path& path) {
  const std::string file = path.string();
  try {
    return read_site(path);
  } catch (const InputError&) {
    throw;
  } catch (const std::bad_alloc&) {
    throw InputError(file, 0, "", "out of memory while reading the file");
  } catch (const std::exception& e) {
    throw InputError(file, 0, "", std::string("cannot read the file: ") + e.what());
  }
}

std::size_t site_machine_index(const Site& site, std::int32_t id) {
  std::string ids;
  for (std::size_t i = 0; i < site.machines.size(); ++i) {
    if (site.machines[i].id == id) return i;
    ids.append(ids.empty() ? "" : ", ").append(std::to_string(site.machines[i].id));
  }
  throw InputError(site.machines_ref.file, site.machines_ref.line, site.machines_ref.field,
                   "no machine with id " + std::to_string(id) + "; expected one of " + ids);
}

}  // namespace mgc::planning::io

// SPDX-License-Identifier: Apache-2.0
#pragma once

// The `geometry:` section of each machine kind, as a table of (field, member). Every field is
// required: a machine file states every dimension it relies on.

#include <variant>

#include "mgc/planning/excavator.hpp"
#include "mgc/planning/mobile_crane.hpp"
#include "mgc/planning/tower_crane.hpp"
#include "yaml_fields.hpp"

namespace mgc::planning::io {

enum class Check { Any, Positive, NonNegative };

template <class G>
struct GeometryField {
  const char* key;
  std::variant<double G::*, Eigen::Vector3d G::*> member;
  Check check;
};

template <class G, std::size_t N>
void read_geometry_table(const Value& value, G& g, const GeometryField<G> (&table)[N]) {
  Fields f = value.fields();
  for (const GeometryField<G>& field : table) {
    const Value v = f.required(field.key);
    if (std::holds_alternative<double G::*>(field.member)) {
      double G::*m = std::get<double G::*>(field.member);
      g.*m = field.check == Check::Positive      ? v.length_m()
               : field.check == Check::NonNegative ? v.non_negative_length_m()
                                                   : v.coordinate_m();
    } else {
      Eigen::Vector3d G::*m = std::get<Eigen::Vector3d G::*>(field.member);
      g.*m = field.check == Check::Positive ? v.size_m() : v.position_m();
    }
  }
  f.finish();
}

inline void read_geometry(const Value& value, MobileCraneGeometry& g) {
  using G = MobileCraneGeometry;
  static const GeometryField<G> table[] = {
      {"carrier_size_m", &G::carrier_size_m, Check::Positive},
      {"carrier_centre_m", &G::carrier_centre_m, Check::Any},
      {"superstructure_size_m", &G::superstructure_size_m, Check::Positive},
      {"superstructure_centre_m", &G::superstructure_centre_m, Check::Any},
      {"boom_foot_forward_m", &G::boom_foot_forward_m, Check::Any},
      {"boom_foot_height_m", &G::boom_foot_height_m, Check::Positive},
      {"boom_width_m", &G::boom_width_m, Check::Positive},
      {"boom_depth_m", &G::boom_depth_m, Check::Positive},
      {"cable_radius_m", &G::cable_radius_m, Check::Positive},
  };
  read_geometry_table(value, g, table);
}

inline void read_geometry(const Value& value, TowerCraneGeometry& g) {
  using G = TowerCraneGeometry;
  static const GeometryField<G> table[] = {
      {"jib_height_m", &G::jib_height_m, Check::Positive},
      {"jib_length_m", &G::jib_length_m, Check::Positive},
      {"counter_jib_length_m", &G::counter_jib_length_m, Check::Positive},
      {"mast_width_m", &G::mast_width_m, Check::Positive},
      {"jib_width_m", &G::jib_width_m, Check::Positive},
      {"jib_depth_m", &G::jib_depth_m, Check::Positive},
      {"counterweight_size_m", &G::counterweight_size_m, Check::Positive},
      {"cable_radius_m", &G::cable_radius_m, Check::Positive},
      {"min_hook_drop_m", &G::min_hook_drop_m, Check::Positive},
  };
  read_geometry_table(value, g, table);
}

inline void read_geometry(const Value& value, ExcavatorGeometry& g) {
  using G = ExcavatorGeometry;
  static const GeometryField<G> table[] = {
      {"boom_length_m", &G::boom_length_m, Check::Positive},
      {"arm_length_m", &G::arm_length_m, Check::Positive},
      {"bucket_length_m", &G::bucket_length_m, Check::Positive},
      {"boom_foot_forward_m", &G::boom_foot_forward_m, Check::Any},
      {"boom_foot_height_m", &G::boom_foot_height_m, Check::Positive},
      {"undercarriage_size_m", &G::undercarriage_size_m, Check::Positive},
      {"undercarriage_centre_m", &G::undercarriage_centre_m, Check::Any},
      {"house_size_m", &G::house_size_m, Check::Positive},
      {"house_centre_m", &G::house_centre_m, Check::Any},
      {"cab_size_m", &G::cab_size_m, Check::Positive},
      {"cab_centre_m", &G::cab_centre_m, Check::Any},
      {"boom_width_m", &G::boom_width_m, Check::Positive},
      {"boom_depth_m", &G::boom_depth_m, Check::Positive},
      {"arm_width_m", &G::arm_width_m, Check::Positive},
      {"arm_depth_m", &G::arm_depth_m, Check::Positive},
      {"bucket_width_m", &G::bucket_width_m, Check::Positive},
      {"bucket_depth_m", &G::bucket_depth_m, Check::Positive},
  };
  read_geometry_table(value, g, table);
}

}  // namespace mgc::planning::io

// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>

#include "mgc/planning/io/input_error.hpp"
#include "mgc/planning/site.hpp"

namespace mgc::planning::io {

//! Lifts in one machine's queue: more are refused (input_limits.hpp's kind of bound).
inline constexpr std::size_t kMaxSiteLifts = 1000;

//! Reads a site file (docs/scenario-format.md, "Site file") and the machine files it names
//! (relative to the site's folder). Every field is checked as in a scenario file, and also: at
//! most kMaxSiteMachines machines, unique ids, unique priorities, unique bus ports or interfaces,
//! unique UWB tag ids, and no two machines whose base footprints (base_footprint()) overlap.
//! Throws InputError with one line naming the file, line and field.
[[nodiscard]] Site load_site(const std::filesystem::path& file);

//! The index of machine `id` in site.machines. An id the site does not list throws InputError
//! naming the site file, the `machines` line and the ids it has (the edge for a --machine-id).
[[nodiscard]] std::size_t site_machine_index(const Site& site, std::int32_t id);

}  // namespace mgc::planning::io

// SPDX-License-Identifier: Apache-2.0
#pragma once

// The site generator: realistic random sites of documented families (docs/sites.md) for the
// mobile crane, the tower crane and the excavator, drawn from a seed and written as ordinary
// scenario files, so any query on them replays with `mgc-plan --scenario <file> --seed S`.

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace mgc::bench {

//! What a family's sites are meant to be.
enum class SiteExpectation : std::uint8_t {
  Solvable,         //!< start and goal valid, a path exists
  ChartInfeasible,  //!< start valid, the goal refused by the load chart (mgc-plan exits 2 naming the row)
  WalledIn,         //!< start and goal valid, no path joins them (mgc-plan exits 1 at its cap)
};

[[nodiscard]] const char* to_string(SiteExpectation expectation) noexcept;

struct SiteFamily {
  std::string name;
  std::string machine;      //!< machine file name in scenarios/machines/
  SiteExpectation expectation = SiteExpectation::Solvable;
  std::string description;  //!< one line for the tables
};

//! Every family, mobile crane first, then tower crane, then excavator.
[[nodiscard]] const std::vector<SiteFamily>& site_families();

//! The family called `name`, or nullptr.
[[nodiscard]] const SiteFamily* find_site_family(const std::string& name);

//! Iteration cap written into every generated file (its planner.max_iterations).
inline constexpr int kSiteMaxIterations = 2000;

//! Draws a family's site tries before the generator gives up on a seed.
inline constexpr int kSiteMaxDraws = 200;

struct GeneratedSite {
  const SiteFamily* family = nullptr;
  std::uint64_t seed = 0;
  std::filesystem::path file;  //!< the written scenario
  int draws = 0;               //!< draws until one met the family's expectation
};

//! Writes the site of `family` for `seed` as <out_dir>/<family>-s<seed>.yaml, with the machine
//! file it names copied from `machines_dir` into <out_dir>/machines/. Each draw is loaded with
//! the normal scenario loader and its start and goal checked against the world mgc-plan builds
//! (CollisionWorld::validate); a draw that does not meet the family's expectation is redrawn, at
//! most kSiteMaxDraws times. The same family and seed give the same file, byte for byte.
//! Throws planning::io::InputError when the machine file does not load (or, a generator bug, a
//! drawn file does not), std::runtime_error when no draw meets the expectation or a file cannot
//! be written.
[[nodiscard]] GeneratedSite generate_site(const SiteFamily& family, std::uint64_t seed,
                                          const std::filesystem::path& machines_dir,
                                          const std::filesystem::path& out_dir);

//! The site of generate_site() with a second machine driving into the work: a mobile crane
//! (carrier and raised boom) on the crane sites, a tipper truck on the excavator's. It drives in
//! along the tangent (18 m for the truck, 45 m or 68 m for a crane) and parks on the bearing
//! halfway between the start's and the goal's tool points (hook, bucket tip), at their mean
//! radius but clear of the machine's own body (at least 5, 8 and 10 m out), arriving
//! 0.5-30.5 s after it could (0.5-2.5 s for the truck at an excavator). Written as
//! <out_dir>/<family>-s<seed>-intruder.yaml; start and goal are checked as generate_site checks
//! them, with the intruder where it stands at the start. The same family and seed give the same
//! file. Throws as generate_site does.
[[nodiscard]] GeneratedSite generate_intruder_site(const SiteFamily& family, std::uint64_t seed,
                                                   const std::filesystem::path& machines_dir,
                                                   const std::filesystem::path& out_dir);

}  // namespace mgc::bench

// SPDX-License-Identifier: Apache-2.0
#pragma once

// The generated coordinated site of N machines (docs/site.md, "Scale"): TMS870 truck cranes and
// tower cranes on a grid, each with one lift in its queue, written as an ordinary site file so
// that any run replays with `mgc-sim --site` or `mgc --site`.

#include <cstdint>
#include <filesystem>

namespace mgc::bench {

//! Distance between neighbouring grid nodes: a TMS870's load (at 12.9 m from its swing axis, the
//! lifts' 20 m boom at 50 deg) reaches into its four neighbours' swing circles and, with the
//! jitter, barely into its diagonal ones, and no two carriers (8.6 m from the axis at most) can
//! touch. [m]
inline constexpr double kScaleSpacing_m = 22.0;
//! Each base is moved off its grid node by up to this much in x and y. [m]
inline constexpr double kScaleJitter_m = 1.0;
//! Least true clearance between any two machines with each at its lift's start or goal, every
//! combination. [m]
inline constexpr double kScaleEndClearance_m = 3.0;
//! Draws of one machine's lift before the generator gives up on a seed.
inline constexpr int kScaleMaxDraws = 100;

struct ScaleSite {
  std::filesystem::path file;  //!< the written site file
  int machines = 0;
  int tower_cranes = 0;
  int redraws = 0;  //!< lifts drawn again because an end met another machine or was invalid
};

//! Writes the site of `machines` machines (1 to 16) for `seed` as
//! <out_dir>/scale-<machines>-s<seed>.yaml, with the two machine files copied from machines_dir
//! into <out_dir>/machines/. The machines stand on a grid of floor(sqrt(N)) rows, kScaleSpacing_m
//! apart, each base moved by up to kScaleJitter_m and turned by a drawn yaw; a tower crane on the
//! last node (from N = 2) and on the first when the two corners stand farther apart than its jib
//! and counter-jib reach (79.7 m, so that two jibs at the same height never meet), TMS870s
//! elsewhere. Priorities 1..N in a drawn order. Each machine's one lift turns its load by 60-120
//! deg either way: the TMS870's at 0.5 m above the ground, 12.9 m out; the tower crane's at a
//! hook height of 30 m (an upper floor), above every TMS870 boom, at a radius of 20-40 m. A lift
//! is drawn again while its start or goal is invalid in its own lift's world; of two machines
//! within kScaleEndClearance_m at their starts or goals, the later one's (or the earlier one's,
//! when it was drawn fewer times: its end may stand on the later one's carrier). The file is loaded with the
//! ordinary site loader before it is returned. The same machines and seed give the same file,
//! byte for byte. Throws std::invalid_argument for machines outside 1..16, planning::io::InputError
//! when a machine file does not load, std::runtime_error when no draw fits or a file cannot be
//! written.
[[nodiscard]] ScaleSite generate_scale_site(int machines, std::uint64_t seed, const std::filesystem::path& machines_dir,
                                            const std::filesystem::path& out_dir);

}  // namespace mgc::bench

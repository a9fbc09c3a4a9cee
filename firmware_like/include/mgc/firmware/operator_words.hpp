// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <mgc/limits.hpp>
#include <mgc/planning/machine_model.hpp>

#include <array>
#include <cstddef>
#include <span>

//! The next moves of a plan in the words a crane or excavator operator uses, e.g.
//! "swing left 32 deg, then boom up 4 deg". Sign conventions (docs/operator-feed.md, from
//! docs/machines.md):
//! - mobile crane (swing, boom_elevation, boom_length, cable_length): swing +  = left (counter-
//!   clockwise seen from above, i.e. to the left of an operator facing the boom), boom + = up,
//!   telescope + = out, cable + = hoist down (a shorter cable lifts the hook);
//! - tower crane (slew, trolley_radius, hook_height): slew + = left, trolley + = out, hook + = up;
//! - excavator (swing, boom, arm, bucket): swing + = left, boom + = up, arm + = out (angles grow
//!   upwards, curling in is negative), bucket + = dump, bucket − = curl.
namespace mgc::firmware {

//! Moves smaller than this are not worth saying (encoder noise, a joint that only holds). [rad | m]
inline constexpr double kWordsMinAngleRad = 0.5 * 3.14159265358979323846 / 180.0;
inline constexpr double kWordsMinLengthM = 0.02;

//! Writes up to max_moves moves into out as NUL-terminated text and returns its length (0 when
//! there is nothing to do). The first move runs from current to waypoints[segment_index + 1], the
//! following ones along the later waypoints; each waypoint is kMaxJoints wide and num_joints
//! entries are used. Segments on which more than one joint moves are said joint by joint with
//! "and". Text that does not fit is cut at a move boundary and ends in ", ...".
//! RT-safe: no alloc, no lock, no throw.
std::size_t next_moves_in_words(planning::MachineKind kind, int num_joints,
                                 std::span<const double> current,
                                 std::span<const std::array<double, kMaxJoints>> waypoints, int segment_index,
                                 int max_moves, std::span<char> out) noexcept;

//! One joint's move in words ("boom up 4 deg") into out; returns its length, 0 if out is too small.
std::size_t joint_move_in_words(planning::MachineKind kind, int joint, double delta,
                                std::span<char> out) noexcept;

}  // namespace mgc::firmware

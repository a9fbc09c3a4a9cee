// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <limits>

namespace mgc::guidance {

//! Position, velocity and acceleration of one joint [m or rad, /s, /s²].
struct JointState {
  double position = 0.0;      //!< [m] or [rad]
  double velocity = 0.0;      //!< [m/s] or [rad/s]
  double acceleration = 0.0;  //!< [m/s²] or [rad/s²]
};

//! One joint's state and the jerk applied at a sampled instant.
struct JointSample {
  double position = 0.0;      //!< [m] or [rad]
  double velocity = 0.0;      //!< [m/s] or [rad/s]
  double acceleration = 0.0;  //!< [m/s²] or [rad/s²]
  double jerk = 0.0;          //!< [m/s³] or [rad/s³]
};

//! The state after moving for t_s [s] with constant jerk from `s` (exact Taylor polynomial). Inline,
//! as is Profile::append: a trajectory calculation calls them a dozen times or more.
[[nodiscard]] inline JointState advance(const JointState& s, double jerk, double t_s) noexcept {
  const double t = t_s;
  // Times 1/6 rather than divided by 6 (a division per call, a dozen calls per trajectory
  // calculation): the term then differs by at most a rounding.
  return {s.position + t * (s.velocity + t * (s.acceleration / 2.0 + t * jerk * (1.0 / 6.0))),
          s.velocity + t * (s.acceleration + t * jerk / 2.0), s.acceleration + t * jerk};
}

//! A one-DoF motion of piecewise-constant jerk: up to kMaxPhases phases from a start state. The
//! state at each phase start is integrated once when the phase is appended, so sampling is exact
//! (a cubic in the time since the phase start) and O(phases). RT-safe: no alloc, no throw.
class Profile {
 public:
  //! Braking segment (up to 4) + seven-phase profile + one spare (a filled profile's ramp to zero
  //! acceleration, docs/trajectory.md).
  static constexpr std::size_t kMaxPhases = 12;

  //! Clears the phases; the profile then holds `start` (with zero jerk) for all time.
  void reset(const JointState& start) noexcept;

  //! Drops every phase from index n on (keeps the first n).
  void truncate(std::size_t n) noexcept {
    if (n < count_) count_ = n;
  }

  //! Appends a phase of constant jerk; phases too short to advance the clock are skipped. False when full.
  [[nodiscard]] bool append(double duration_s, double jerk) noexcept {
    // A phase too short to move the clock could never be sampled; its effect on the state is below
    // the rounding of the time itself.
    if (!(start_time_s_[count_] + duration_s > start_time_s_[count_])) return true;
    if (count_ >= kMaxPhases) return false;
    duration_s_[count_] = duration_s;
    jerk_[count_] = jerk;
    JointState& end = start_state_[count_ + 1];
    end = advance(start_state_[count_], jerk, duration_s);
    // A ramp meant to end at zero acceleration ends a few roundings of the profile's accelerations
    // off it; over a following cruise of duration T that residue would move the velocity by
    // residue T and the position by residue T^2/2 (1e-8 m after 5000 s), so an acceleration within
    // 64 roundings of the largest one so far is zero.
    acceleration_scale_ = std::max({acceleration_scale_, std::abs(start_state_[count_].acceleration),
                                    std::abs(start_state_[count_].acceleration + jerk * duration_s)});
    if (std::abs(end.acceleration) <= 64.0 * std::numeric_limits<double>::epsilon() * acceleration_scale_) {
      end.acceleration = 0.0;
    }
    start_time_s_[count_ + 1] = start_time_s_[count_] + duration_s;
    ++count_;
    return true;
  }

  //! State at time t since the profile start [s]. Before 0 the start; after the end the end state
  //! advanced with zero jerk (a profile ending at rest then holds still).
  [[nodiscard]] JointSample at_time(double t_s) const noexcept;

  [[nodiscard]] double duration() const noexcept { return start_time_s_[count_]; }  //!< [s]
  [[nodiscard]] std::size_t phase_count() const noexcept { return count_; }
  [[nodiscard]] double phase_duration(std::size_t i) const noexcept { return duration_s_[i]; }  //!< [s]
  [[nodiscard]] double phase_jerk(std::size_t i) const noexcept { return jerk_[i]; }  //!< [/s³]
  //! State at the start of phase i; i == phase_count() gives the end state.
  [[nodiscard]] const JointState& state_at_phase(std::size_t i) const noexcept { return start_state_[i]; }
  [[nodiscard]] double phase_start_time(std::size_t i) const noexcept { return start_time_s_[i]; }  //!< [s]
  [[nodiscard]] const JointState& end_state() const noexcept { return start_state_[count_]; }

  //! Number of leading phases that bring a start back within the limits (0 when none) [-].
  std::size_t brake_phase_count = 0;

 private:
  std::size_t count_ = 0;
  double acceleration_scale_ = 0.0;  //!< [m/s²] largest |a| at a phase start or end so far
  std::array<double, kMaxPhases> duration_s_{};
  std::array<double, kMaxPhases> jerk_{};
  std::array<JointState, kMaxPhases + 1> start_state_{};
  std::array<double, kMaxPhases + 1> start_time_s_{};
};

}  // namespace mgc::guidance

// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "mgc/planning/machine_model.hpp"

namespace mgc::planning {

//! A joint trajectory through via configurations, after seed 002's post-processing (§2.6): in
//! every joint a cubic spline over a virtual time tau in [0, 1], run in real time
//! t = k_tau * tau with the one scalar k_tau that keeps every joint within its velocity and
//! acceleration limits (uniform kinematic scaling; the duration is then k_tau seconds).
//!
//! Knots sit at the cumulative "simultaneous" time of the via-to-via chords,
//! sum of max_j |dq_j| / max_velocity_j, so the scaled trajectory uses the joints' speed evenly.
//! Continuous joints are unwrapped across the vias (the short way round) and wrapped again on
//! output. reserve() sizes the storage; fit() and every evaluation are RT-safe (no allocation,
//! no throw).
class SplineTrajectory {
 public:
  enum class Shape : std::uint8_t {
    //! Clamped cubic spline: C2, at rest at both ends (zero end velocities), free at the vias.
    Spline,
    //! Rest to rest between consecutive vias, q = y_i + (3 s^2 - 2 s^3) (y_{i+1} - y_i): C1, and
    //! every segment stays on the straight joint-space edge between its vias.
    StopAtVias,
  };

  //! Room for `max_vias` vias. May allocate.
  void reserve(std::size_t max_vias);
  //! Fits the trajectory through `vias` (consecutive duplicates skipped) for `model`'s joint
  //! limits. False, and empty, when there are more vias than reserved, fewer than two distinct
  //! ones, or a joint has a non-positive velocity or acceleration limit.
  [[nodiscard]] bool fit(const MachineModel& model, std::span<const JointVector> vias, Shape shape) noexcept;

  [[nodiscard]] bool empty() const noexcept { return tau_.size() < 2; }
  [[nodiscard]] Shape shape() const noexcept { return shape_; }
  //! Real time per unit of virtual time; equal to the duration. [s]
  [[nodiscard]] double k_tau() const noexcept { return k_tau_; }
  [[nodiscard]] double duration_s() const noexcept { return k_tau_; }
  //! Vias kept (distinct) = knots; segments = knots - 1.
  [[nodiscard]] std::size_t knots() const noexcept { return tau_.size(); }
  [[nodiscard]] double knot_tau(std::size_t i) const noexcept { return tau_[i]; }

  //! Position at virtual time tau in [0, 1] (clamped), continuous joints wrapped. [rad | m]
  [[nodiscard]] JointVector position_at_tau(double tau) const noexcept;
  //! Position, velocity and acceleration at real time t_s in [0, duration_s()] (clamped).
  //! [rad | m], [rad/s | m/s], [rad/s^2 | m/s^2]
  [[nodiscard]] JointVector position(double t_s) const noexcept;
  [[nodiscard]] JointVector velocity(double t_s) const noexcept;
  [[nodiscard]] JointVector acceleration(double t_s) const noexcept;

  //! Largest |dq_j / dtau| over segment `segment` (between knots segment and segment + 1), per
  //! joint: with the segment's virtual length it bounds how far each joint moves within it.
  [[nodiscard]] JointVector max_rate(std::size_t segment) const noexcept;

 private:
  //! Segment holding tau and the derivatives there with respect to tau (order 0, 1 or 2).
  [[nodiscard]] JointVector evaluate(double tau, int order) const noexcept;
  //! Largest |dq_j / dtau| and |d2q_j / dtau2| of joint j over segment i.
  [[nodiscard]] double max_rate(std::size_t i, int j) const noexcept;
  [[nodiscard]] double max_curvature(std::size_t i, int j) const noexcept;

  Shape shape_ = Shape::Spline;
  int dof_ = 0;
  double k_tau_ = 0.0;
  std::vector<double> tau_;         //!< knots, 0 = tau_0 < ... < tau_n = 1
  std::vector<JointVector> y_;      //!< unwrapped vias at the knots [rad | m]
  std::vector<JointVector> m_;      //!< d2q/dtau2 at the knots (Spline only)
  std::array<bool, kMaxJoints> continuous_{};  //!< per joint: wrap on output
  std::vector<double> scratch_c_;   //!< tridiagonal solve
  std::vector<double> scratch_d_;
};

}  // namespace mgc::planning

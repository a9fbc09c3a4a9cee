// SPDX-License-Identifier: Apache-2.0
#include "mgc/planning/spline_trajectory.hpp"

#include <algorithm>
#include <cmath>

namespace mgc::planning {

void SplineTrajectory::reserve(std::size_t max_vias) {
  tau_.reserve(max_vias);
  y_.reserve(max_vias);
  m_.reserve(max_vias);
  scratch_c_.reserve(max_vias);
  scratch_d_.reserve(max_vias);
}

bool SplineTrajectory::fit(const MachineModel& model, std::span<const JointVector> vias, Shape shape) noexcept {
  tau_.clear();
  y_.clear();
  m_.clear();
  k_tau_ = 0.0;
  shape_ = shape;
  dof_ = model.dof();
  if (vias.size() < 2 || vias.size() > tau_.capacity()) return false;
  const auto joints = model.joints();
  for (int j = 0; j < dof_; ++j) {
    const JointSpec& spec = joints[static_cast<std::size_t>(j)];
    if (!(spec.max_velocity > 0.0) || !(spec.max_acceleration > 0.0)) return false;
    continuous_[static_cast<std::size_t>(j)] = spec.continuous;
  }

  // Unwrap, drop repeats, and place each knot by the chord's time at full speed of its slowest
  // joint (virtual time before normalisation).
  y_.push_back(vias[0]);
  tau_.push_back(0.0);
  for (std::size_t k = 1; k < vias.size(); ++k) {
    const JointVector d = model.difference(vias[k - 1], vias[k]);
    double chord_s = 0.0;
    for (int j = 0; j < dof_; ++j) chord_s = std::max(chord_s, std::abs(d[j]) / joints[static_cast<std::size_t>(j)].max_velocity);
    if (chord_s == 0.0) continue;
    y_.push_back(y_.back() + d);
    tau_.push_back(tau_.back() + chord_s);
  }
  if (tau_.size() < 2) {
    tau_.clear();
    y_.clear();
    return false;
  }
  const double total_s = tau_.back();
  for (double& t : tau_) t /= total_s;
  tau_.back() = 1.0;
  const std::size_t n = tau_.size() - 1;  // segments

  JointVector zero = JointVector::Zero(dof_);
  m_.assign(n + 1, zero);
  if (shape_ == Shape::Spline) {
    // Second derivatives M at the knots: the clamped spline's tridiagonal system (zero end
    // velocities), solved per joint by the Thomas algorithm; it is diagonally dominant.
    scratch_c_.assign(n + 1, 0.0);
    scratch_d_.assign(n + 1, 0.0);
    const auto h = [this](std::size_t i) { return tau_[i + 1] - tau_[i]; };
    for (int j = 0; j < dof_; ++j) {
      const auto slope = [&](std::size_t i) { return (y_[i + 1][j] - y_[i][j]) / h(i); };
      for (std::size_t i = 0; i <= n; ++i) {
        const double a = i == 0 ? 0.0 : h(i - 1);
        const double c = i == n ? 0.0 : h(i);
        const double b = 2.0 * (a + c);
        const double rhs = 6.0 * ((i == n ? 0.0 : slope(i)) - (i == 0 ? 0.0 : slope(i - 1)));
        const double denom = b - (i == 0 ? 0.0 : a * scratch_c_[i - 1]);
        scratch_c_[i] = c / denom;
        scratch_d_[i] = (rhs - (i == 0 ? 0.0 : a * scratch_d_[i - 1])) / denom;
      }
      m_[n][j] = scratch_d_[n];
      for (std::size_t i = n; i-- > 0;) m_[i][j] = scratch_d_[i] - scratch_c_[i] * m_[i + 1][j];
    }
  }

  // Uniform scaling (seed 002 §2.6): dq/dt = q' / k and d2q/dt2 = q'' / k^2, so
  // k = max(max |q'_j| / v_j, sqrt(max |q''_j| / a_j)) over every joint and instant.
  double k = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    for (int j = 0; j < dof_; ++j) {
      const JointSpec& spec = joints[static_cast<std::size_t>(j)];
      k = std::max({k, max_rate(i, j) / spec.max_velocity, std::sqrt(max_curvature(i, j) / spec.max_acceleration)});
    }
  }
  k_tau_ = k;
  return true;
}

JointVector SplineTrajectory::evaluate(double tau, int order) const noexcept {
  tau = std::clamp(tau, 0.0, 1.0);
  const std::size_t n = tau_.size() - 1;
  const auto above = std::upper_bound(tau_.begin(), tau_.end(), tau);
  const std::size_t i = std::min(n - 1, static_cast<std::size_t>(std::max<std::ptrdiff_t>(0, above - tau_.begin() - 1)));
  const double h = tau_[i + 1] - tau_[i];
  const double b = tau - tau_[i];
  const double a = tau_[i + 1] - tau;
  const JointVector& y0 = y_[i];
  const JointVector& y1 = y_[i + 1];
  if (shape_ == Shape::StopAtVias) {
    const double s = b / h;
    const JointVector delta = y1 - y0;
    switch (order) {
      case 0: return y0 + (s * s * (3.0 - 2.0 * s)) * delta;
      case 1: return (6.0 * s * (1.0 - s) / h) * delta;
      default: return ((6.0 - 12.0 * s) / (h * h)) * delta;
    }
  }
  const JointVector& m0 = m_[i];
  const JointVector& m1 = m_[i + 1];
  switch (order) {
    case 0:
      return (a * a * a / (6.0 * h)) * m0 + (b * b * b / (6.0 * h)) * m1 + (a / h) * (y0 - (h * h / 6.0) * m0) +
             (b / h) * (y1 - (h * h / 6.0) * m1);
    case 1: return (-a * a / (2.0 * h)) * m0 + (b * b / (2.0 * h)) * m1 + (y1 - y0) / h - (h / 6.0) * (m1 - m0);
    default: return (a / h) * m0 + (b / h) * m1;
  }
}

JointVector SplineTrajectory::position_at_tau(double tau) const noexcept {
  JointVector q = evaluate(tau, 0);
  for (int j = 0; j < dof_; ++j) {
    if (continuous_[static_cast<std::size_t>(j)]) q[j] = wrap_angle(q[j]);
  }
  return q;
}

JointVector SplineTrajectory::position(double t_s) const noexcept { return position_at_tau(t_s / k_tau_); }

JointVector SplineTrajectory::velocity(double t_s) const noexcept { return evaluate(t_s / k_tau_, 1) / k_tau_; }

JointVector SplineTrajectory::acceleration(double t_s) const noexcept {
  return evaluate(t_s / k_tau_, 2) / (k_tau_ * k_tau_);
}

double SplineTrajectory::max_rate(std::size_t i, int j) const noexcept {
  const double h = tau_[i + 1] - tau_[i];
  const double delta = y_[i + 1][j] - y_[i][j];
  if (shape_ == Shape::StopAtVias) return 1.5 * std::abs(delta) / h;  // at s = 1/2
  const double m0 = m_[i][j];
  const double m1 = m_[i + 1][j];
  const double mean = delta / h - (m1 - m0) * h / 6.0;
  // q' at both ends, and at the inner extremum where q'' (linear) crosses zero.
  double rate = std::max(std::abs(mean - m0 * h / 2.0), std::abs(mean + m1 * h / 2.0));
  if (m0 * m1 < 0.0) {
    const double b = -m0 * h / (m1 - m0);
    const double a = h - b;
    rate = std::max(rate, std::abs(mean - m0 * a * a / (2.0 * h) + m1 * b * b / (2.0 * h)));
  }
  return rate;
}

double SplineTrajectory::max_curvature(std::size_t i, int j) const noexcept {
  if (shape_ == Shape::StopAtVias) {
    const double h = tau_[i + 1] - tau_[i];
    return 6.0 * std::abs(y_[i + 1][j] - y_[i][j]) / (h * h);  // at s = 0 and 1
  }
  // q'' is linear on the segment: its largest magnitude is at an end.
  return std::max(std::abs(m_[i][j]), std::abs(m_[i + 1][j]));
}

JointVector SplineTrajectory::max_rate(std::size_t segment) const noexcept {
  JointVector rate(dof_);
  for (int j = 0; j < dof_; ++j) rate[j] = max_rate(segment, j);
  return rate;
}

}  // namespace mgc::planning

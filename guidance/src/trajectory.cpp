// SPDX-License-Identifier: Apache-2.0
// Time-optimal jerk-limited 1-DoF profiles to a rest target (docs/trajectory.md). Every profile of
// the seven-phase family (Berscheid & Kröger, RSS 2021) is: a velocity change from the start state
// to a peak velocity vp at zero acceleration, a cruise at vp (only at |vp| = max velocity), and a
// velocity change from vp to rest. For a given vp both velocity changes are unique (and
// time-optimal), so the family is one-parametric: the fastest member either cruises at ±vmax, or
// has no cruise and a vp that solves D(vp) = distance. D is piecewise smooth in vp with known
// breakpoints and square-root ends; each piece is searched for all roots after a smoothstep change
// of variable that removes the square roots.
#include "mgc/guidance/trajectory.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>

namespace mgc::guidance {
namespace {

//! Three phases of jerk (+s j_max, 0, -s j_max) taking (v0, a0) to (vt, 0).
struct VelocityChange {
  double t1 = 0.0, t2 = 0.0, t3 = 0.0;  //!< [s]
  double jerk = 0.0;                    //!< jerk of the first phase; the third has -jerk
};

//! The time-optimal change from (v0, a0), |a0| <= a_max, to (vt, 0): jerk towards vt until the
//! peak acceleration, an optional plateau at ±a_max, jerk back to zero. The direction s is fixed
//! by where the velocity would stop if the acceleration were ramped to zero at once (v_az).
VelocityChange velocity_change(double v0, double a0, double vt, double a_max, double j_max) noexcept {
  const double v_az = v0 + a0 * std::abs(a0) / (2.0 * j_max);
  const double s = vt >= v_az ? 1.0 : -1.0;
  const double a0m = s * a0;  // mirrored so that the change is upwards
  const double dv = s * (vt - v0);
  // The peak is at least a0m in exact arithmetic (s was chosen so); when vt is v_az up to
  // rounding, keep it there so that the ramp still ends at zero acceleration.
  const double ap = std::max(std::sqrt(std::max(j_max * dv + a0m * a0m / 2.0, 0.0)), a0m);
  VelocityChange c;
  c.jerk = s * j_max;
  if (ap <= a_max) {
    c.t1 = (ap - a0m) / j_max;
    c.t3 = ap / j_max;
  } else {
    c.t1 = std::max((a_max - a0m) / j_max, 0.0);
    c.t3 = a_max / j_max;
    c.t2 = std::max((dv - (a_max * a_max - a0m * a0m) / (2.0 * j_max) - a_max * a_max / (2.0 * j_max)) / a_max, 0.0);
  }
  return c;
}

JointState apply(const JointState& s, const VelocityChange& c) noexcept {
  return advance(advance(advance(s, c.jerk, c.t1), 0.0, c.t2), -c.jerk, c.t3);
}

//! The no-cruise family member with peak velocity vp: distance covered and duration.
struct Member {
  double distance = 0.0;  //!< [m]
  double duration = 0.0;  //!< [s]
};

//! Which family a candidate belongs to.
enum class Shape : std::uint8_t { PeakVelocity, EarlyTurn };

struct Family {
  static constexpr Shape kShape = Shape::PeakVelocity;
  double v0, a0, a_max, j_max;

  [[nodiscard]] Member at(double vp) const noexcept {
    const VelocityChange c1 = velocity_change(v0, a0, vp, a_max, j_max);
    const VelocityChange c2 = velocity_change(vp, 0.0, 0.0, a_max, j_max);
    const JointState end = apply(apply({0.0, v0, a0}, c1), c2);
    return {end.position, c1.t1 + c1.t2 + c1.t3 + c2.t1 + c2.t2 + c2.t3};
  }
};

//! The profiles whose acceleration does not pass through zero before the stop (Ruckig's UDDU with
//! an empty cruise and a first jerk phase too short to bring the acceleration to zero): from
//! a0 != 0, jerk towards zero for t1 < |a0|/j_max, then the velocity change to rest, which drives
//! the acceleration away from zero again and back. The peak-velocity family cannot hold them: it
//! only splits a profile where the acceleration is zero. Parameter: t1 [s]. Only used when the
//! velocity at zero acceleration keeps the sign it would stop from (v_az * a0 < 0), which makes the
//! change to rest push the acceleration further the same way, so the velocity stays between v0 and 0.
struct EarlyTurn {
  static constexpr Shape kShape = Shape::EarlyTurn;
  double v0, a0, a_max, j_max;

  [[nodiscard]] Member at(double t1) const noexcept {
    const JointState turn = advance({0.0, v0, a0}, a0 < 0.0 ? j_max : -j_max, t1);
    const VelocityChange c = velocity_change(turn.velocity, turn.acceleration, 0.0, a_max, j_max);
    const JointState end = apply(turn, c);
    return {end.position, t1 + c.t1 + c.t2 + c.t3};
  }
};

//! Peak velocity of piece [lo, hi] at u in [0, 1]: a smoothstep, so that square-root behaviour at
//! either end becomes smooth in u.
double piece_vp(double lo, double hi, double u) noexcept { return lo + (hi - lo) * (u * u * (3.0 - 2.0 * u)); }

template <class F>
struct PieceFunction {
  const F* family;
  double lo, hi, distance;
  [[nodiscard]] double operator()(double u) const noexcept { return family->at(piece_vp(lo, hi, u)).distance - distance; }
};

//! Root of f in [ua, ub] where f(ua), f(ub) differ in sign: Illinois regula falsi with a bisection
//! step whenever the bracket shrinks too slowly, to the last representable u.
template <class F>
double bracketed_root(const PieceFunction<F>& f, double ua, double fa, double ub, double fb) noexcept {
  int side = 0;
  for (int i = 0; i < 200; ++i) {
    const double width = ub - ua;
    double u = (fa * ub - fb * ua) / (fa - fb);
    if (!(u > ua && u < ub) || i % 4 == 3) u = ua + width / 2.0;  // safeguard: bisection
    if (u <= ua || u >= ub) break;                                 // no representable point left
    const double fu = f(u);
    if (fu == 0.0) return u;
    if ((fu < 0.0) == (fa < 0.0)) {
      ua = u;
      fa = fu;
      if (side == -1) fb /= 2.0;
      side = -1;
    } else {
      ub = u;
      fb = fu;
      if (side == 1) fa /= 2.0;
      side = 1;
    }
  }
  return std::abs(fa) <= std::abs(fb) ? ua : ub;
}

struct Best {
  double duration = std::numeric_limits<double>::infinity();  //!< [s]
  double vp = 0.0;             //!< [m/s] peak velocity, or [s] the turn time t1 of an EarlyTurn
  double cruise = 0.0;         //!< [s]
  Shape shape = Shape::PeakVelocity;
};

template <class F>
void consider_root(const F& family, double x, Best& best) noexcept {
  const double duration = family.at(x).duration;
  if (duration < best.duration) best = {duration, x, 0.0, F::kShape};
}

//! All roots of D(vp) = distance on one piece: sign changes over a sample grid, plus a search of
//! each grid-level local minimum of |f| for a pair of roots between two samples (a near tangency).
template <class F>
void search_piece(const F& family, double lo, double hi, double distance, Best& best) noexcept {
  constexpr int kSamples = 8;
  const PieceFunction<F> f{&family, lo, hi, distance};
  std::array<double, kSamples + 1> fs{};
  for (int i = 0; i <= kSamples; ++i) fs[static_cast<std::size_t>(i)] = f(static_cast<double>(i) / kSamples);
  for (int i = 0; i <= kSamples; ++i) {
    const auto k = static_cast<std::size_t>(i);
    const double u = static_cast<double>(i) / kSamples;
    if (fs[k] == 0.0) {
      consider_root(family, piece_vp(lo, hi, u), best);
      continue;
    }
    if (i == kSamples) break;
    const double un = static_cast<double>(i + 1) / kSamples;
    if (fs[k + 1] != 0.0 && (fs[k] < 0.0) != (fs[k + 1] < 0.0)) {
      consider_root(family, piece_vp(lo, hi, bracketed_root(f, u, fs[k], un, fs[k + 1])), best);
    }
    if (i == 0) continue;
    // Near tangency: f keeps its sign at the samples but may cross zero twice between them.
    const double sign = fs[k] < 0.0 ? -1.0 : 1.0;
    if (sign * fs[k - 1] <= 0.0 || sign * fs[k + 1] <= 0.0 || sign * fs[k] > sign * fs[k - 1] ||
        sign * fs[k] > sign * fs[k + 1]) {
      continue;
    }
    double a = static_cast<double>(i - 1) / kSamples, b = un;
    constexpr double kInvPhi = 0.6180339887498949;
    double c = b - kInvPhi * (b - a), d = a + kInvPhi * (b - a);
    double fc = sign * f(c), fd = sign * f(d);
    for (int it = 0; it < 60 && fc > 0.0 && fd > 0.0; ++it) {
      if (fc < fd) {
        b = d;
        d = c;
        fd = fc;
        c = b - kInvPhi * (b - a);
        fc = sign * f(c);
      } else {
        a = c;
        c = d;
        fc = fd;
        d = a + kInvPhi * (b - a);
        fd = sign * f(d);
      }
    }
    const double um = fc <= fd ? c : d;
    const double fm = std::min(fc, fd) * sign;
    if (sign * fm > 0.0) continue;
    if (fm == 0.0) {
      consider_root(family, piece_vp(lo, hi, um), best);
      continue;
    }
    const double ul = static_cast<double>(i - 1) / kSamples;
    consider_root(family, piece_vp(lo, hi, bracketed_root(f, ul, fs[k - 1], um, fm)), best);
    consider_root(family, piece_vp(lo, hi, bracketed_root(f, um, fm, un, fs[k + 1])), best);
  }
}

bool finite(double x) noexcept { return std::isfinite(x); }

//! Appends the braking pre-phase: bring |a| to a_max, then, if the velocity is or will be beyond
//! v_max, follow the time-optimal velocity change to (±v_max, 0) until the first instant where
//! |v| <= v_max and the velocity at zero acceleration is inside the limits too.
bool append_brake(const JointLimits& lim, Profile& out) noexcept {
  const double v_max = lim.max_velocity, a_max = lim.max_acceleration, j_max = lim.max_jerk;
  JointState st = out.end_state();
  if (st.acceleration > a_max) {
    if (!out.append((st.acceleration - a_max) / j_max, -j_max)) return false;
  } else if (st.acceleration < -a_max) {
    if (!out.append((-a_max - st.acceleration) / j_max, j_max)) return false;
  }
  st = out.end_state();
  st.acceleration = std::clamp(st.acceleration, -a_max, a_max);  // rounding of the ramp above
  const auto v_at_zero_a = [j_max](const JointState& s) {
    return s.velocity + s.acceleration * std::abs(s.acceleration) / (2.0 * j_max);
  };
  const double v_az = v_at_zero_a(st);
  if (std::abs(st.velocity) <= v_max && std::abs(v_az) <= v_max) return true;
  const double side = std::abs(v_az) > v_max ? (v_az > 0.0 ? 1.0 : -1.0) : (st.velocity > 0.0 ? 1.0 : -1.0);
  const VelocityChange c = velocity_change(st.velocity, st.acceleration, side * v_max, a_max, j_max);
  const std::array<double, 3> durations{c.t1, c.t2, c.t3};
  const std::array<double, 3> jerks{c.jerk, 0.0, -c.jerk};
  for (std::size_t i = 0; i < 3; ++i) {
    // First downward crossing of side*v = v_max in this phase (side*a <= 0 there).
    const double j = side * jerks[i], a = side * st.acceleration, dv = side * st.velocity - v_max;
    double t_cross = std::numeric_limits<double>::infinity();
    if (j == 0.0) {
      if (a < 0.0 && dv >= 0.0) t_cross = -dv / a;
    } else {
      const double disc = a * a - 2.0 * j * dv;
      if (disc >= 0.0) {
        const double r = std::sqrt(disc);
        for (const double t : {(-a - r) / j, (-a + r) / j}) {
          if (t >= 0.0 && a + j * t <= 0.0 && t < t_cross) t_cross = t;
        }
      }
    }
    if (t_cross <= durations[i]) {
      const JointState at = advance(st, jerks[i], t_cross);
      if (std::abs(v_at_zero_a(at)) <= v_max) {
        return out.append(t_cross, jerks[i]);
      }
    }
    if (!out.append(durations[i], jerks[i])) return false;
    st = out.end_state();
  }
  return true;
}

}  // namespace

namespace {

CalculationResult validate(const JointState& start, const JointLimits& limits) noexcept {
  const auto invalid = [](InvalidField f) { return CalculationResult{TrajectoryStatus::ErrorInvalidInput, f}; };
  if (!(finite(limits.max_velocity) && limits.max_velocity > 0.0)) return invalid(InvalidField::MaxVelocity);
  if (!(finite(limits.max_acceleration) && limits.max_acceleration > 0.0)) return invalid(InvalidField::MaxAcceleration);
  if (!(finite(limits.max_jerk) && limits.max_jerk > 0.0)) return invalid(InvalidField::MaxJerk);
  if (!finite(start.position)) return invalid(InvalidField::CurrentPosition);
  if (!finite(start.velocity)) return invalid(InvalidField::CurrentVelocity);
  if (!finite(start.acceleration)) return invalid(InvalidField::CurrentAcceleration);
  return {};
}

}  // namespace

CalculationResult calculate_stop(const JointState& start, const JointLimits& limits, Profile& out) noexcept {
  out.reset(start);
  if (const CalculationResult r = validate(start, limits); !r.ok()) return r;
  if (!append_brake(limits, out)) return {TrajectoryStatus::ErrorNoSolution, InvalidField::None};
  out.brake_phase_count = out.phase_count();
  const JointState& s = out.end_state();
  const double a = std::clamp(s.acceleration, -limits.max_acceleration, limits.max_acceleration);
  const VelocityChange c = velocity_change(s.velocity, a, 0.0, limits.max_acceleration, limits.max_jerk);
  if (!(out.append(c.t1, c.jerk) && out.append(c.t2, 0.0) && out.append(c.t3, -c.jerk))) {
    return {TrajectoryStatus::ErrorNoSolution, InvalidField::None};
  }
  return {};
}

CalculationResult calculate_time_optimal(const JointState& start, double target_position, const JointLimits& limits,
                                         Profile& out) noexcept {
  out.reset(start);
  if (const CalculationResult r = validate(start, limits); !r.ok()) return r;
  if (!finite(target_position)) return {TrajectoryStatus::ErrorInvalidInput, InvalidField::TargetPosition};

  if (!append_brake(limits, out)) return {TrajectoryStatus::ErrorNoSolution, InvalidField::None};
  out.brake_phase_count = out.phase_count();
  JointState s = out.end_state();
  s.acceleration = std::clamp(s.acceleration, -limits.max_acceleration, limits.max_acceleration);

  const double v_max = limits.max_velocity, a_max = limits.max_acceleration, j_max = limits.max_jerk;
  const Family family{s.velocity, s.acceleration, a_max, j_max};
  const double distance = target_position - s.position;

  Best best;
  for (const double vp : {v_max, -v_max}) {  // cruise members
    const Member m = family.at(vp);
    const double cruise = (distance - m.distance) / vp;
    if (cruise >= 0.0 && m.duration + cruise < best.duration) best = {m.duration + cruise, vp, cruise, Shape::PeakVelocity};
  }
  // Breakpoints of D(vp): zero acceleration reached at once, plateaus begin, zero peak velocity.
  const double v_az = s.velocity + s.acceleration * std::abs(s.acceleration) / (2.0 * j_max);
  const double plateau = (a_max * a_max - s.acceleration * s.acceleration / 2.0) / j_max;
  std::array<double, 8> cuts{-v_max, v_max, v_az, s.velocity + plateau, s.velocity - plateau,
                             a_max * a_max / j_max, -a_max * a_max / j_max, 0.0};
  for (double& c : cuts) c = std::clamp(c, -v_max, v_max);
  std::sort(cuts.begin(), cuts.end());
  for (std::size_t i = 0; i + 1 < cuts.size(); ++i) {
    if (cuts[i + 1] > cuts[i]) search_piece(family, cuts[i], cuts[i + 1], distance, best);
  }
  const double a0 = s.acceleration;
  if ((a0 < 0.0 && v_az > 0.0) || (a0 > 0.0 && v_az < 0.0)) {
    // Mirrored so that a0 < 0: the change to rest after the turn reaches the plateau where
    // j^2 t1^2 + 2 j a0 t1 + j v0 + a0^2/2 - a_max^2 = 0 (its peak acceleration squared is j v + a^2/2).
    const double am = -std::abs(a0), vm = a0 < 0.0 ? s.velocity : -s.velocity;
    const double t_zero = -am / j_max;
    const EarlyTurn turn{s.velocity, a0, a_max, j_max};
    std::array<double, 4> turn_cuts{0.0, t_zero, t_zero, t_zero};
    const double disc = a_max * a_max - j_max * vm + am * am / 2.0;
    if (disc >= 0.0) {
      turn_cuts[1] = std::clamp((-am - std::sqrt(disc)) / j_max, 0.0, t_zero);
      turn_cuts[2] = std::clamp((-am + std::sqrt(disc)) / j_max, 0.0, t_zero);
    }
    std::sort(turn_cuts.begin(), turn_cuts.end());
    for (std::size_t i = 0; i + 1 < turn_cuts.size(); ++i) {
      if (turn_cuts[i + 1] > turn_cuts[i]) search_piece(turn, turn_cuts[i], turn_cuts[i + 1], distance, best);
    }
  }
  if (!std::isfinite(best.duration)) return {TrajectoryStatus::ErrorNoSolution, InvalidField::None};

  if (best.shape == Shape::EarlyTurn) {
    if (!out.append(best.vp, a0 < 0.0 ? j_max : -j_max)) return {TrajectoryStatus::ErrorNoSolution, InvalidField::None};
  } else {
    const VelocityChange c1 = velocity_change(s.velocity, s.acceleration, best.vp, a_max, j_max);
    if (!(out.append(c1.t1, c1.jerk) && out.append(c1.t2, 0.0) && out.append(c1.t3, -c1.jerk))) {
      return {TrajectoryStatus::ErrorNoSolution, InvalidField::None};
    }
  }
  // The cruise and the final velocity change are built from the state actually reached, and a
  // cruise is re-timed once from the position error: over a long cruise, a velocity rounding error
  // at the end of the first change would otherwise grow into a position error.
  const std::size_t cruise_index = out.phase_count();
  bool appended = true;
  for (int pass = 0; pass < 2; ++pass) {
    out.truncate(cruise_index);
    const JointState& peak = out.end_state();
    const VelocityChange c2 = velocity_change(peak.velocity, peak.acceleration, 0.0, a_max, j_max);
    appended = out.append(best.cruise, 0.0) && out.append(c2.t1, c2.jerk) && out.append(c2.t2, 0.0) &&
               out.append(c2.t3, -c2.jerk);
    if (!(best.cruise > 0.0)) break;
    best.cruise = std::max(best.cruise - (out.end_state().position - target_position) / peak.velocity, 0.0);
  }
  const JointState& end = out.end_state();
  if (!appended || !(std::abs(end.position - target_position) <= 1e-8) || !(std::abs(end.velocity) <= 1e-9) ||
      !(std::abs(end.acceleration) <= 1e-9)) {
    return {TrajectoryStatus::ErrorNoSolution, InvalidField::None};
  }
  return {};
}

}  // namespace mgc::guidance

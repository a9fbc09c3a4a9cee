// SPDX-License-Identifier: Apache-2.0
// Time-optimal jerk-limited 1-DoF profiles to a rest target (docs/trajectory.md), in closed form per
// profile type as in Ruckig (Berscheid & Kröger, RSS 2021). After the braking segment the
// time-optimal profile to rest has the jerk pattern UDDU (+J, plateau, -J, cruise, -J, plateau, +J,
// J = ±j_max); each subset of reached limits leaves one unknown and a polynomial of degree <= 4,
// whose real roots are all found, and the fastest valid profile wins.
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

//! The limits and the reciprocals a calculation multiplies by, computed once: a division costs
//! several multiplications, and a calculation makes a few dozen.
struct Lim {
  double v_max, a_max, j_max;
  double inv_j, inv_2j, inv_a, inv_v;
  explicit Lim(const JointLimits& l) noexcept
      : v_max(l.max_velocity),
        a_max(l.max_acceleration),
        j_max(l.max_jerk),
        inv_j(1.0 / l.max_jerk),
        inv_2j(0.5 / l.max_jerk),
        inv_a(1.0 / l.max_acceleration),
        inv_v(1.0 / l.max_velocity) {}
};

//! The time-optimal change from (v0, a0), |a0| <= a_max, to (vt, 0): jerk towards vt until the
//! peak acceleration, an optional plateau at ±a_max, jerk back to zero. The direction s is fixed
//! by where the velocity would stop if the acceleration were ramped to zero at once (v_az).
//! Inline (as is apply): a calculation calls it four to six times, often with constant arguments
//! (rest as the target, zero start acceleration); inlined, a calculation takes about 10% less time.
inline VelocityChange velocity_change(double v0, double a0, double vt, const Lim& l) noexcept {
  const double v_az = v0 + a0 * std::abs(a0) * l.inv_2j;
  const double s = vt >= v_az ? 1.0 : -1.0;
  const double a0m = s * a0;  // mirrored so that the change is upwards
  const double dv = s * (vt - v0);
  // The peak is at least a0m in exact arithmetic (s was chosen so); when vt is v_az up to
  // rounding, keep it there so that the ramp still ends at zero acceleration.
  const double ap = std::max(std::sqrt(std::max(l.j_max * dv + a0m * a0m / 2.0, 0.0)), a0m);
  VelocityChange c;
  c.jerk = s * l.j_max;
  if (ap <= l.a_max) {
    c.t1 = (ap - a0m) * l.inv_j;
    c.t3 = ap * l.inv_j;
  } else {
    c.t1 = std::max((l.a_max - a0m) * l.inv_j, 0.0);
    c.t3 = l.a_max * l.inv_j;
    c.t2 = std::max((dv - (2.0 * l.a_max * l.a_max - a0m * a0m) * l.inv_2j) * l.inv_a, 0.0);
  }
  return c;
}

inline JointState apply(const JointState& s, const VelocityChange& c) noexcept {
  return advance(advance(advance(s, c.jerk, c.t1), 0.0, c.t2), -c.jerk, c.t3);
}

//! Distance of the change c from (v, 0) to rest: its velocity is point-symmetric about the
//! change's middle, so it covers v/2 times the change's duration (no need to integrate the phases).
double distance_to_rest(double v, const VelocityChange& c) noexcept { return v * (c.t1 + c.t2 + c.t3) / 2.0; }

//! Real roots in [lo, hi] of c[0] + c[1] x + ... + c[n] x^n, n <= 6, ascending, written to out (room
//! for n). Each root is isolated between consecutive critical points (the derivative's roots,
//! found the same way) and polished by Newton steps kept inside its bracket, so clustered and
//! nearly double roots are not lost to the cancellation of the closed-form quartic formulas.
constexpr int kMaxDegree = 6;

// The degree is a template parameter so that the loops over the coefficients unroll.
template <int n>
double poly_eval(const double* c, double x) noexcept {
  double r = c[n];
  for (int k = n - 1; k >= 0; --k) r = r * x + c[k];
  return r;
}

//! The root of c in [a, b], where the values at a (fa) and b (fb) differ in sign: Newton steps from
//! the secant point, a bisection whenever a step would leave the bracket.
template <int n>
double polish(const double* c, double a, double fa, double b, double fb, double rel_tol) noexcept {
  double x = (a * fb - b * fa) / (fb - fa);
  if (!(x > a && x < b)) x = a + (b - a) / 2.0;
  // Relative to the bracket's magnitude, so that a root at or near zero stops as soon as one
  // elsewhere would.
  const double tol = rel_tol * std::max({std::abs(a), std::abs(b), b - a});
  for (int it = 0; it < 100; ++it) {
    double f = c[n], df = 0.0;
    for (int k = n - 1; k >= 0; --k) {
      df = df * x + f;
      f = f * x + c[k];
    }
    if (f == 0.0) return x;
    if ((f < 0.0) == (fa < 0.0)) {
      a = x;
      fa = f;
    } else {
      b = x;
      fb = f;
    }
    double next = x - f / df;
    // Converged: checked before the bracket test, since x is now an end of the bracket and a step
    // of rounding size often leaves it, which would restart the slow secant and bisection steps.
    if (std::abs(next - x) <= tol) return next >= a && next <= b ? next : x;
    if (!(next > a && next < b)) {
      // Newton left the bracket (or df was 0): the secant of the bracket, halved values at an end
      // kept twice would be better still, but a bisection every other time bounds the iterations.
      next = (it % 2 == 0) ? (a * fb - b * fa) / (fb - fa) : a + (b - a) / 2.0;
      if (!(next > a && next < b)) next = a + (b - a) / 2.0;
    }
    if (std::abs(next - x) <= tol || !(b - a > tol)) return next;
    x = next;
  }
  return x;
}

//! True when c certainly has no root in [lo, hi]: the value at the midpoint exceeds what the other
//! Taylor terms can change it by over the half-width. Most profile types have no root in their
//! interval; this skips them without isolating the critical points.
template <int n>
bool no_root(const double* c, double lo, double hi) noexcept {
  const double m = lo + (hi - lo) / 2.0, r = (hi - lo) / 2.0;
  std::array<double, kMaxDegree + 1> t{};  // Taylor coefficients at m, by repeated synthetic division
  for (int k = 0; k <= n; ++k) t[static_cast<std::size_t>(k)] = c[k];
  for (int i = 0; i <= n; ++i) {
    for (int k = n - 1; k >= i; --k) t[static_cast<std::size_t>(k)] += m * t[static_cast<std::size_t>(k) + 1];
  }
  double bound = 0.0, rk = 1.0;
  for (int k = 1; k <= n; ++k) {
    rk *= r;
    bound += std::abs(t[static_cast<std::size_t>(k)]) * rk;
  }
  return std::abs(t[0]) > bound * (1.0 + 1e-12);
}

// real_roots strips zero leading coefficients, real_roots_of_degree solves degrees 1 and 2 in
// closed form, isolated_roots the others between critical points.
template <int n>
int real_roots_of_degree(const double* c, double lo, double hi, double* out, double rel_tol) noexcept;
template <int n>
int isolated_roots(const double* c, double lo, double hi, double* out, double rel_tol) noexcept;

//! rel_tol: the relative step at which polishing stops; the critical points of the level above only
//! isolate its roots and need less than full precision.
template <int n>
int real_roots(const double* c, double lo, double hi, double* out,
               double rel_tol = 4.0 * std::numeric_limits<double>::epsilon()) noexcept {
  if constexpr (n == 0) {
    return 0;
  } else {
    if (c[n] == 0.0) return real_roots<n - 1>(c, lo, hi, out, rel_tol);
    if (!(lo <= hi)) return 0;
    return real_roots_of_degree<n>(c, lo, hi, out, rel_tol);
  }
}

template <int n>
int real_roots_of_degree(const double* c, double lo, double hi, double* out, double rel_tol) noexcept {
  if constexpr (n == 1) {
    const double x = -c[0] / c[1];
    if (!(x >= lo && x <= hi)) return 0;
    out[0] = x;
    return 1;
  } else if constexpr (n == 2) {
    // The stable quadratic formula; a slightly negative discriminant is a double root lifted off
    // the axis by rounding.
    const double disc = c[1] * c[1] - 4.0 * c[2] * c[0];
    std::array<double, 2> x{};
    int m = 0;
    if (disc >= 0.0) {
      const double q = -(c[1] + std::copysign(std::sqrt(disc), c[1])) / 2.0;
      x = {q / c[2], q != 0.0 ? c[0] / q : q / c[2]};
      if (x[0] > x[1]) std::swap(x[0], x[1]);
      m = 2;
    } else if (disc >= -1e-12 * c[1] * c[1]) {
      x[0] = -c[1] / (2.0 * c[2]);
      m = 1;
    }
    int count = 0;
    for (int i = 0; i < m; ++i) {
      if (x[static_cast<std::size_t>(i)] >= lo && x[static_cast<std::size_t>(i)] <= hi) out[count++] = x[static_cast<std::size_t>(i)];
    }
    return count;
  } else {
    return isolated_roots<n>(c, lo, hi, out, rel_tol);
  }
}

template <int n>
int isolated_roots(const double* c, double lo, double hi, double* out, double rel_tol) noexcept {
  if (no_root<n>(c, lo, hi)) return 0;
  std::array<double, n> dc{};
  for (int k = 0; k < n; ++k) dc[static_cast<std::size_t>(k)] = (k + 1) * c[k + 1];
  std::array<double, n + 1> cuts{};
  cuts[0] = lo;
  const int m = real_roots<n - 1>(dc.data(), lo, hi, cuts.data() + 1, 1e-10);
  cuts[static_cast<std::size_t>(m) + 1] = hi;
  int count = 0;
  double fa = poly_eval<n>(c, lo);
  if (fa == 0.0) out[count++] = lo;
  for (int i = 0; i <= m && count < n; ++i) {
    const double a = cuts[static_cast<std::size_t>(i)], b = cuts[static_cast<std::size_t>(i) + 1];
    const double fb = poly_eval<n>(c, b);
    if (fb == 0.0) {
      out[count++] = b;
    } else if (fa != 0.0 && (fa < 0.0) != (fb < 0.0)) {
      out[count++] = polish<n>(c, a, fa, b, fb, rel_tol);
    } else if (i < m) {
      // A critical point whose value is zero up to rounding: a double root that rounding lifted off
      // the axis. Accepting it is safe, every candidate is checked when it is built.
      double scale = 0.0, xk = 1.0;
      for (int k = 0; k <= n; ++k, xk *= std::abs(b)) scale += std::abs(c[k]) * xk;
      if (std::abs(fb) <= 1e-11 * scale) out[count++] = b;
    }
    fa = fb;
  }
  return count;
}

//! Newton steps on the unsquared position equation of a NONE profile, P(x) + r(x) Q(x) = d with
//! r = -sqrt(x^2 + c) (UDDU, branch -1) or sqrt(-(x^2 + c)) (UDUD, branch +1): next to the ends of
//! [lo, hi], where r has a square-root end, the squared polynomial's root is ill-conditioned in x.
double polish_none(double x, double lo, double hi, double v0, double a0, double d, double J, double branch) noexcept {
  const double c = J * v0 - a0 * a0 / 2.0, J_2 = J * J, a0_2 = a0 * a0;
  for (int it = 0; it < 3; ++it) {
    const double r_sq = -branch * (x * x + c);
    if (!(r_sq > 0.0)) break;
    const double r = branch * std::sqrt(r_sq);
    const double p = (-3.0 * J * a0 * v0 + 6.0 * J * v0 * x + a0 * a0_2 - 3.0 * a0_2 * x + 3.0 * x * x * x) / (3.0 * J_2);
    const double q = branch * (2.0 * c + 2.0 * x * x) / (2.0 * J_2);
    const double dp = (6.0 * J * v0 - 3.0 * a0_2 + 9.0 * x * x) / (3.0 * J_2);
    const double dr = -branch * x / r;
    const double dq = branch * 2.0 * x / J_2;
    const double f = p + r * q - d, df = dp + dr * q + r * dq;
    const double next = x - f / df;
    if (!(next >= lo && next <= hi)) break;
    x = next;
  }
  return x;
}

//! A candidate profile after the braking segment, in the frame mirrored so that its first jerk is
//! +j_max (jerk_sign -1 undoes the mirror): a head (jerk J for t0, a plateau t1, jerk -J for t2), a
//! cruise of cruise_s, and the time-optimal stop from the state reached. For a no-cruise profile
//! the head is its first ramp and plateau (for UDUD also the ramp to zero acceleration); for a
//! cruise member it is the time-optimal change to the cruise velocity, kept from the solving so
//! that building does not compute it again.
//! No default member values: every candidate is written in full when added, and the unused slots
//! of Candidates are then left unwritten (initialising all of them cost more than the solving).
struct Candidate {
  double duration_s;
  double t0_s, t1_s, t2_s;  //!< [s] the head's phases
  //! +1, or -1 when the head's first ramp has jerk -J (a change to the cruise velocity whose start
  //! rounding put above it)
  double head_sign;
  double cruise_s;  //!< [s], 0 for a no-cruise profile
  double jerk_sign;
  //! [m/s] (mirrored) velocity where the acceleration passes through zero between the change to
  //! it and the change to rest (> 0 for UDDU, < 0 for UDUD); 0 for an early turn, which has none.
  double peak_velocity;
  bool tried;  //!< built once and failed the end-state check
};

constexpr std::size_t kMaxCandidates = 32;

//! Only items[0, count) are meaningful.
struct Candidates {
  std::array<Candidate, kMaxCandidates> items;
  std::size_t count = 0;
  void add(const Candidate& c) noexcept {
    if (count < items.size() && std::isfinite(c.duration_s)) items[count++] = c;
  }
};

//! Tolerances of the validity checks on a candidate: durations a rounding below zero are empty
//! phases, and the limits hold to 1e-12 relative (as the tests check).
constexpr double kTimeTolerance = 1e-12;
constexpr double kLimitTolerance = 1e-12;

//! The cruise at +v_max (the caller mirrors v0, a0, d for -v_max): the time-optimal change to
//! v_max, a cruise, the time-optimal change to rest. False when the changes alone pass d.
//! `tail` receives the change to rest from v_max (mirrored).
bool vel_candidate(double v0, double a0, double d, const Lim& L, double jerk_sign, Candidate& out,
                   VelocityChange& tail) noexcept {
  const VelocityChange c1 = velocity_change(v0, a0, L.v_max, L);
  const VelocityChange c2 = velocity_change(L.v_max, 0.0, 0.0, L);
  tail = c2;
  const double changes_distance = apply({0.0, v0, a0}, c1).position + distance_to_rest(L.v_max, c2);
  const double cruise = (d - changes_distance) * L.inv_v;
  if (!(cruise >= 0.0)) return false;
  out = {c1.t1 + c1.t2 + c1.t3 + cruise + c2.t1 + c2.t2 + c2.t3, c1.t1, c1.t2, c1.t3, c1.jerk > 0.0 ? 1.0 : -1.0,
         cruise, jerk_sign, L.v_max, false};
  return true;
}

//! The UDDU candidates with first jerk +j (the caller mirrors v0, a0, d for -j): jerk +J to the
//! acceleration x (or a plateau at A = a_max), -J to z <= 0 (or a plateau at -A), +J to zero; the
//! velocity ends at zero when z^2 = x^2 + c with c = J v0 - a0^2/2. Each type (neither plateau,
//! ACC0, ACC1, both) leaves one unknown and a polynomial from the position; the cruise at +v_max
//! (VEL) is closed-form. x < 0 is allowed: the acceleration turns towards zero without reaching
//! it before the stop (the "early turn").
//! try_vel false: the caller found the cruise at v_max of this direction passing d already.
void uddu_candidates(double v0, double a0, double d, const Lim& L, double jerk_sign, Candidates& out,
                     bool try_vel = true) noexcept {
  const double J = L.j_max, A = L.a_max, v_max = L.v_max;
  const double c = J * v0 - a0 * a0 / 2.0;
  const double v_lim = v_max * (1.0 + kLimitTolerance);
  std::array<double, kMaxDegree> roots{};
  const auto add = [&](double duration, double t0, double t1, double peak_velocity) {
    out.add({duration, std::max(t0, 0.0), std::max(t1, 0.0), 0.0, 1.0, 0.0, jerk_sign, peak_velocity, false});
  };
  const double a0_2 = a0 * a0, a0_3 = a0_2 * a0, J_2 = J * J, v0_2 = v0 * v0;
  // Terms of the position equation shared by the plateau types.
  const double shared = -24.0 * A * J_2 * d - 24.0 * A * J * a0 * v0 + 8.0 * A * a0_3;
  // The checks below on a root, as bounds on the square of the acceleration it gives, so that each
  // type's interval holds only roots they can accept (most of those intervals are then empty, or
  // have no root by the Taylor bound): the peak velocity v0 + (2 x^2 - a0^2)/(2 J) of an x > 0,
  // and z^2/J of ACC0's, is at most v_lim when x^2 (z^2) <= J v_lim - c (J v_lim); a plateau is
  // not shorter than -kTimeTolerance when x^2 >= A^2 - c (ACC1) or z^2 >= A^2 + c (ACC0). Each bound
  // is widened by a margin well above its rounding, so no root the checks accept is left out.
  const double margin = 1e-9 * (J * v_lim + std::abs(c) + A * A) + kTimeTolerance * A * J;
  const double peak_sq = J * v_lim - c + margin;

  // VEL: cruise at +v_max. Every other type of this direction peaks below v_max and so covers less
  // than the changes to and from it: with a cruise left over, none of them reaches d.
  {
    Candidate vel;
    VelocityChange tail;
    if (try_vel && vel_candidate(v0, a0, d, L, jerk_sign, vel, tail)) {
      out.add(vel);
      return;
    }
  }
  // NONE: unknown x in [a0, A] with x^2 + c in [0, A^2]; the position is P(x) + z Q(x) = d with
  // z = -sqrt(x^2 + c), squared into a quartic (its spurious roots, z > 0, fail the residual).
  {
    double lo = a0, hi = A;
    if (c < 0.0) lo = std::max(lo, std::sqrt(-c));
    if (A * A - c < 0.0) hi = lo - 1.0;
    else hi = std::min({hi, std::sqrt(A * A - c), std::sqrt(std::max(peak_sq, 0.0))});
    // The coefficients only for an interval that is not empty (most are not).
    if (lo <= hi) {
      const double k = 2.0 * c, h = 3.0 * J_2 * d + 3.0 * J * a0 * v0 - a0_3;
      const double coef[5] = {(-72.0 * J_2 * J_2 * d * d - 144.0 * J_2 * J * a0 * d * v0 +
                               72.0 * J_2 * J * v0_2 * v0 + 48.0 * J_2 * a0_3 * d - 180.0 * J_2 * a0_2 * v0_2 +
                               102.0 * J * a0_2 * a0_2 * v0 - 17.0 * a0_3 * a0_3) / 72.0,
                              2.0 / 3.0 * k * h, -k * k / 4.0, 2.0 / 3.0 * h, -k / 2.0};
      const int n = real_roots<4>(coef, lo, hi, roots.data());
      for (int i = 0; i < n; ++i) {
        const double x = polish_none(roots[static_cast<std::size_t>(i)], lo, hi, v0, a0, d, J, -1.0);
        const double z = -std::sqrt(std::max(x * x + c, 0.0));
        const double p =
            (-3.0 * J * a0 * v0 + 6.0 * J * v0 * x + a0_3 - 3.0 * a0_2 * x + 3.0 * x * x * x) / (3.0 * J_2);
        const double q = -(k + 2.0 * x * x) / (2.0 * J_2);
        if (!(std::abs(p + z * q - d) <= 1e-6 * (std::abs(p) + std::abs(z * q) + std::abs(d)))) continue;
        if (x < z - kTimeTolerance * J) continue;
        const double peak = x > 0.0 ? v0 + (2.0 * x * x - a0_2) / (2.0 * J) : 0.0;
        if (peak > v_lim) continue;
        add((2.0 * x - a0 - 2.0 * z) / J, (x - a0) / J, 0.0, peak);
      }
    }
  }
  // ACC0: x = A; unknown z in [-A, 0]; t1 = (z^2 - A^2 - c)/(A J).
  {
    const double z_lo = -std::sqrt(std::min(A * A, std::max(J * v_lim + margin, 0.0)));
    const double z_hi = -std::sqrt(std::max(A * A + c - margin, 0.0));
    if (z_lo <= z_hi) {
      const double coef[5] = {12.0 * A * A * J * v0 - 6.0 * A * A * a0_2 + shared - 12.0 * J_2 * v0_2 +
                                  12.0 * J * a0_2 * v0 - 3.0 * a0_2 * a0_2,
                              0.0, 12.0 * A * A, -24.0 * A, 12.0};
      const int n = real_roots<4>(coef, z_lo, z_hi, roots.data());
      for (int i = 0; i < n; ++i) {
        const double z = roots[static_cast<std::size_t>(i)];
        const double t1 = (z * z - A * A - c) / (A * J);
        if (t1 < -kTimeTolerance) continue;
        const double peak = v0 + (A * A - a0_2) / (2.0 * J) + A * std::max(t1, 0.0) + A * A / (2.0 * J);
        if (peak > v_lim) continue;
        add((A - a0) / J + std::max(t1, 0.0) + (A - 2.0 * z) / J, (A - a0) / J, t1, peak);
      }
    }
  }
  // ACC1: z = -A; unknown x in [max(a0, -A), A]; t5 = (x^2 - A^2 + c)/(A J).
  {
    // x <= -x_min (an early turn, the peak check not applying) or x in [x_min, x_max].
    const double x_min = std::sqrt(std::max(A * A - c - margin, 0.0));
    const double x_max = std::min(A, std::sqrt(std::max(peak_sq, 0.0)));
    const double lo = std::max(a0, -A);
    if (lo <= -x_min || (x_min > 0.0 ? std::max(lo, x_min) : lo) <= x_max) {
      const double k = 2.0 * J * v0 - a0_2;
      const double coef[5] = {12.0 * A * A * J * v0 - 6.0 * A * A * a0_2 + shared + 12.0 * J_2 * v0_2 -
                                  12.0 * J * a0_2 * v0 + 3.0 * a0_2 * a0_2,
                              24.0 * A * k, 12.0 * (A * A + k), 24.0 * A, 12.0};
      std::array<double, 2 * 4> split_roots{};  // up to four in each part
      int n = 0;
      if (x_min > 0.0) n = real_roots<4>(coef, lo, -x_min, split_roots.data());
      n += real_roots<4>(coef, x_min > 0.0 ? std::max(lo, x_min) : lo, x_max, split_roots.data() + n);
      for (int i = 0; i < n; ++i) {
        const double x = split_roots[static_cast<std::size_t>(i)];
        const double t5 = (x * x - A * A + c) / (A * J);
        if (t5 < -kTimeTolerance) continue;
        const double peak = x > 0.0 ? v0 + (2.0 * x * x - a0_2) / (2.0 * J) : 0.0;
        if (peak > v_lim) continue;
        add((x - a0) / J + (x + A) / J + std::max(t5, 0.0) + A / J, (x - a0) / J, 0.0, peak);
      }
    }
  }
  // ACC0_ACC1: x = A, z = -A; unknown t1 >= 0; t5 = t1 + c/(A J).
  // Its peak velocity is at least (A^2 + c)/J (ACC0 too): skipped when that is beyond v_lim.
  if (A * A + c <= J * v_lim + margin) {
    const double coef[3] = {48.0 * A * A * A * A + 84.0 * A * A * J * v0 - 42.0 * A * A * a0_2 + shared +
                                12.0 * J_2 * v0_2 - 12.0 * J * a0_2 * v0 + 3.0 * a0_2 * a0_2,
                            24.0 * A * J * (3.0 * A * A + 2.0 * J * v0 - a0_2), 24.0 * A * A * J_2};
    // Degree two: the stable quadratic formula (c2 > 0); a slightly negative discriminant is a
    // double root lifted by rounding.
    const double disc = coef[1] * coef[1] - 4.0 * coef[2] * coef[0];
    int n = 0;
    if (disc >= -1e-12 * coef[1] * coef[1]) {
      const double q = -(coef[1] + std::copysign(std::sqrt(std::max(disc, 0.0)), coef[1])) / 2.0;
      roots[0] = q / coef[2];
      roots[1] = q != 0.0 ? coef[0] / q : roots[0];
      n = 2;
    }
    for (int i = 0; i < n; ++i) {
      const double t1 = roots[static_cast<std::size_t>(i)];
      const double t5 = t1 + c / (A * J);
      if (t1 < -kTimeTolerance || t5 < -kTimeTolerance) continue;
      const double peak = v0 + (A * A - a0_2) / (2.0 * J) + A * t1 + A * A / (2.0 * J);
      if (peak > v_lim) continue;
      add((A - a0) / J + t1 + 3.0 * A / J + std::max(t5, 0.0), (A - a0) / J, t1, peak);
    }
  }
}

bool finite(double x) noexcept { return std::isfinite(x); }

//! Appends the braking segment (docs/trajectory.md, "Starts that must brake"). An acceleration
//! beyond a_max is ramped to ±a_max at full jerk, the earliest it can be inside. Then, if the
//! velocity is beyond ±v_max or will be whatever the jerk does (its value at zero acceleration
//! v + a|a|/(2 j_max) is beyond), the jerk brings it back at the earliest instant from which it
//! can stay within: in the frame where it must be pushed up, full jerk (the acceleration held at
//! a_max once there) bounds every velocity from above, so the velocity is back at -v_max no
//! earlier than along it, and only along it; from there it stays within when the acceleration is
//! at most a_cap = sqrt(4 j_max v_max) (its value at zero acceleration is then at most v_max).
//! Otherwise it would overshoot +v_max, and the earliest entry that stays within follows full
//! jerk up to the parabola of states whose velocity at zero acceleration is v_max, then -j_max
//! along it down to (-v_max, a_cap). Closed form, no iteration.
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
  const double v_az = st.velocity + st.acceleration * std::abs(st.acceleration) / (2.0 * j_max);
  if (std::abs(st.velocity) <= v_max && std::abs(v_az) <= v_max) return true;
  // The frame where the velocity is pushed up into the band: below it now or bound to go below
  // (a velocity above it whose value at zero acceleration is inside just comes down into it).
  const double s = v_az < -v_max ? 1.0 : v_az > v_max ? -1.0 : (st.velocity < 0.0 ? 1.0 : -1.0);
  const double v = s * st.velocity, a = s * st.acceleration, jerk = s * j_max;
  // The velocity comes back to v_in, inside v_max by 16 roundings of the largest velocity in the
  // braking (which can be hundreds of times v_max), so that rounding never leaves it beyond.
  const double v_in =
      v_max - 16.0 * std::numeric_limits<double>::epsilon() * std::max({std::abs(v), std::abs(v_az), v_max});
  const double v_at_amax = v + (a_max * a_max - a * a) / (2.0 * j_max);
  // Full jerk until the velocity is back at -v_in (on its rising side), with the acceleration a_e
  // it then has; a plateau at a_max if the ramp reaches it first.
  double rise_s = 0.0, plateau_s = 0.0, a_e = 0.0;
  if (v_at_amax >= -v_in) {
    a_e = std::sqrt(std::max(a * a - 2.0 * j_max * (v + v_in), 0.0));
    rise_s = std::max((a_e - a) / j_max, 0.0);
  } else {
    a_e = a_max;
    rise_s = std::max((a_max - a) / j_max, 0.0);
    plateau_s = (-v_in - v_at_amax) / a_max;
  }
  const double a_cap = std::sqrt(4.0 * j_max * v_in);
  if (a_e <= a_cap) return out.append(rise_s, jerk) && out.append(plateau_s, 0.0);
  // The switch onto the parabola v = v_in - a^2/(2 j_max), where full jerk from (v, a) meets it.
  const double a_s = std::sqrt(j_max * (v_in - v) + a * a / 2.0);
  if (a_s <= a_max) {
    return out.append(std::max((a_s - a) / j_max, 0.0), jerk) && out.append((a_s - a_cap) / j_max, -jerk);
  }
  const double to_parabola_s = (v_in - a_max * a_max / (2.0 * j_max) - v_at_amax) / a_max;
  return out.append(std::max((a_max - a) / j_max, 0.0), jerk) && out.append(std::max(to_parabola_s, 0.0), 0.0) &&
         out.append((a_max - a_cap) / j_max, -jerk);
}

//! The UDUD candidates with first jerk +j (mirrored as for UDDU): jerk +J to x >= 0 (or a plateau at
//! A), -J to zero acceleration at a velocity vp < 0, +J to w >= 0 (or a plateau at A), -J to zero;
//! the velocity ends at zero when x^2 + w^2 = -c. They are needed when the target lies just short
//! of where the time-optimal stop would end: the stop has jerk pattern +J, -J, and stopping a little
//! earlier means reaching a velocity between the one at zero acceleration and zero first. Both
//! velocity extremes (at zero acceleration) lie between that velocity and zero, inside the limits.
void udud_candidates(double v0, double a0, double d, const Lim& L, double jerk_sign, Candidates& out) noexcept {
  const double J = L.j_max, A = L.a_max;
  const double c = J * v0 - a0 * a0 / 2.0;
  if (!(c < 0.0)) return;  // no vp < 0 with zero acceleration is reachable by a +J first ramp
  std::array<double, kMaxDegree> roots{};
  const double a0_2 = a0 * a0, a0_3 = a0_2 * a0, J_2 = J * J, v0_2 = v0 * v0;
  const auto add = [&](double duration, double t0, double t1, double t2, double peak_velocity) {
    out.add({duration, std::max(t0, 0.0), std::max(t1, 0.0), std::max(t2, 0.0), 1.0, 0.0, jerk_sign, peak_velocity,
             false});
  };
  // Velocity at the zero acceleration between the ramps, after a plateau of t1 at A.
  const auto plateau_peak = [&](double t1) { return v0 + (A * A - a0_2) / (2.0 * J) + A * t1 + A * A / (2.0 * J); };
  const double shared = -24.0 * A * J_2 * d - 24.0 * A * J * a0 * v0 + 8.0 * A * a0_3;
  const double plateau_c0 = 12.0 * A * A * J * v0 - 6.0 * A * A * a0_2 + shared - 12.0 * J_2 * v0_2 +
                            12.0 * J * a0_2 * v0 - 3.0 * a0_2 * a0_2;
  const double x_lo = std::max(a0, 0.0);
  // NONE: unknown x with w = sqrt(-(x^2 + c)) in [0, A]; P(x) + w Q(x) = d squared into a sextic.
  {
    const double k = 2.0 * c, h = 3.0 * J_2 * d + 3.0 * J * a0 * v0 - a0_3;
    const double coef[7] = {-(72.0 * J_2 * J_2 * d * d + 144.0 * J_2 * J * a0 * d * v0 + 72.0 * J_2 * J * v0_2 * v0 -
                              48.0 * J_2 * a0_3 * d - 36.0 * J_2 * a0_2 * v0_2 + 6.0 * J * a0_2 * a0_2 * v0 -
                              a0_3 * a0_3) / 72.0,
                            2.0 / 3.0 * k * h, -7.0 / 4.0 * k * k, 2.0 / 3.0 * h, -7.0 / 2.0 * k, 0.0, -2.0};
    const double lo = std::max(x_lo, std::sqrt(std::max(-c - A * A, 0.0)));
    const double hi = std::min(A, std::sqrt(-c));
    const int n = real_roots<6>(coef, lo, hi, roots.data());
    for (int i = 0; i < n; ++i) {
      const double x = polish_none(roots[static_cast<std::size_t>(i)], lo, hi, v0, a0, d, J, 1.0);
      const double w = std::sqrt(std::max(-(x * x + c), 0.0));
      const double p = (-3.0 * J * a0 * v0 + 6.0 * J * v0 * x + a0_3 - 3.0 * a0_2 * x + 3.0 * x * x * x) / (3.0 * J_2);
      const double q = (k + 2.0 * x * x) / (2.0 * J_2);
      if (!(std::abs(p + w * q - d) <= 1e-6 * (std::abs(p) + std::abs(w * q) + std::abs(d)))) continue;
      add((2.0 * x - a0 + 2.0 * w) / J, (x - a0) / J, 0.0, x / J, -w * w / J);
    }
  }
  // A plateau is not shorter than -kTimeTolerance when the acceleration w (ACC0) or x (ACC1) of the
  // other ramp pair has a square at most -(A^2 + c) (widened as in the UDDU types): the only part
  // of the interval where a root can be accepted.
  const double plateau_sq = -(A * A + c) + 1e-9 * (A * A + std::abs(c)) + kTimeTolerance * A * J;
  const double plateau_hi = plateau_sq >= 0.0 ? std::min(A, std::sqrt(plateau_sq)) : -1.0;
  // ACC0: x = A; unknown w in [0, A]; t1 = -(A^2 + c + w^2)/(A J).
  {
    const double coef[5] = {plateau_c0, 0.0, -12.0 * A * A, -24.0 * A, 12.0};
    const int n = real_roots<4>(coef, 0.0, plateau_hi, roots.data());
    for (int i = 0; i < n; ++i) {
      const double w = roots[static_cast<std::size_t>(i)];
      const double t1 = -(A * A + c + w * w) / (A * J);
      if (t1 < -kTimeTolerance) continue;
      add((A - a0) / J + std::max(t1, 0.0) + (A + 2.0 * w) / J, (A - a0) / J, t1, A / J, plateau_peak(t1));
    }
  }
  // ACC1: w = A; unknown x in [max(a0, 0), A]; t5 = -(A^2 + c + x^2)/(A J).
  {
    const double k = 2.0 * J * v0 - a0_2;
    const double coef[5] = {plateau_c0, 24.0 * A * k, -12.0 * (k - A * A), 24.0 * A, -12.0};
    const int n = real_roots<4>(coef, x_lo, plateau_hi, roots.data());
    for (int i = 0; i < n; ++i) {
      const double x = roots[static_cast<std::size_t>(i)];
      const double t5 = -(A * A + c + x * x) / (A * J);
      if (t5 < -kTimeTolerance) continue;
      add((2.0 * x - a0) / J + 2.0 * A / J + std::max(t5, 0.0), (x - a0) / J, 0.0, x / J, (x * x + c) / J);
    }
  }
  // ACC0_ACC1: x = w = A; unknown t1 >= 0 (linear); t5 = -t1 - (2 A^2 + c)/(A J).
  {
    const double c0 = 24.0 * A * A * A * A + 36.0 * A * A * J * v0 - 18.0 * A * A * a0_2 + shared - 12.0 * J_2 * v0_2 +
                      12.0 * J * a0_2 * v0 - 3.0 * a0_2 * a0_2;
    const double t1 = -c0 / (24.0 * A * A * A * J);
    const double t5 = -t1 - (2.0 * A * A + c) / (A * J);
    if (t1 >= -kTimeTolerance && t5 >= -kTimeTolerance) {
      add((A - a0) / J + std::max(t1, 0.0) + 3.0 * A / J + std::max(t5, 0.0), (A - a0) / J, t1, A / J,
          plateau_peak(t1));
    }
  }
}

//! The profile ends at rest at the target: to 1e-8 in position, or, for moves whose positions and
//! cruise distance reach beyond 1e6, to 32 roundings of them (double precision cannot hold 1e-8
//! there); to 1e-9 in velocity and acceleration, or 64 roundings of their limits beyond 1e7.
bool reaches(const Profile& out, double target_position, const Lim& L) noexcept {
  constexpr double eps = std::numeric_limits<double>::epsilon();
  const JointState& end = out.end_state();
  const double position_scale =
      std::abs(out.state_at_phase(0).position) + std::abs(target_position) + L.v_max * out.duration();
  return std::abs(end.position - target_position) <= std::max(1e-8, 32.0 * eps * position_scale) &&
         std::abs(end.velocity) <= std::max(1e-9, 64.0 * eps * L.v_max) &&
         std::abs(end.acceleration) <= std::max(1e-9, 64.0 * eps * L.a_max);
}

//! Appends the candidate's phases to `out` (which ends after the braking segment) and checks the
//! end state. The stop (or change to rest) is built from the state actually reached, so it ends at
//! zero velocity and acceleration exactly; a cruise is re-timed once from the position error, so
//! that a velocity rounding error is not multiplied by a long cruise.
//! A no-cruise UDDU candidate's head (a ramp of t0, a plateau of t1) from the root of its type's
//! polynomial: next to where a plateau vanishes that polynomial is ill-conditioned, and a short
//! move's end position hardly notices, so the root can be off by parts in a million of the
//! duration while the end is within 1e-8. When the end misses the target by more than roundings,
//! secant steps on the head's unknown (the plateau if there is one, else the ramp) on the end
//! position integrated as the profile will be (at most 4; kept only if the miss shrinks).
//! `e` is the built profile's miss; true when a head that misses less was found.
bool refine_head(const JointState& from, double jerk, double target_position, const Lim& L, double tolerance,
                 double e, double& t0, double& t1) noexcept {
  const auto miss = [&](double r0, double r1) {
    JointState head = advance(advance(from, jerk, r0), 0.0, r1);
    head.acceleration = std::clamp(head.acceleration, -L.a_max, L.a_max);
    return apply(head, velocity_change(head.velocity, head.acceleration, 0.0, L)).position - target_position;
  };
  const bool plateau = t1 > 0.0;
  double x = plateau ? t1 : t0;
  double x_prev = x * (1.0 + 1e-7) + 1e-12, e_prev = plateau ? miss(t0, x_prev) : miss(x_prev, t1);
  double best_x = x, best_e = std::abs(e);
  for (int i = 0; i < 4 && e != e_prev; ++i) {
    const double next = std::max(x - e * (x - x_prev) / (e - e_prev), 0.0);
    x_prev = x;
    e_prev = e;
    x = next;
    e = plateau ? miss(t0, x) : miss(x, t1);
    if (std::abs(e) < best_e) {
      best_e = std::abs(e);
      best_x = x;
    }
    if (!(std::abs(e) > tolerance)) break;
  }
  if (best_x == (plateau ? t1 : t0)) return false;
  (plateau ? t1 : t0) = best_x;
  return true;
}

//! `tail`, when given, is the change to rest from the cruise velocity (mirrored as the candidate),
//! used when the head ends at zero acceleration instead of computing it again.
bool build(const Candidate& c, double target_position, const Lim& L, Profile& out,
           const VelocityChange* tail = nullptr) noexcept {
  const double a_max = L.a_max, j_max = L.j_max;
  const double jerk = c.jerk_sign * c.head_sign * j_max;
  const std::size_t first = out.phase_count();
  const JointState from = out.end_state();
  const auto append_all = [&](double t0, double t1) {
    if (!(out.append(t0, jerk) && out.append(t1, 0.0) && out.append(c.t2_s, -jerk))) return false;
    JointState head = out.end_state();
    head.acceleration = std::clamp(head.acceleration, -a_max, a_max);
    VelocityChange stop;
    if (tail != nullptr && head.acceleration == 0.0) {
      stop = *tail;
      stop.jerk *= c.jerk_sign;
    } else {
      stop = velocity_change(head.velocity, head.acceleration, 0.0, L);
    }
    double cruise = c.cruise_s;
    if (cruise > 0.0) {
      // The re-timing changes only the cruise, so the stop is the same after it. The end position
      // without appending the phases only to drop them again: when the head ends at zero
      // acceleration (Profile::append zeroes a rounding residue), the stop covers v/2 times its
      // duration; otherwise integrated as append will.
      const double end_position =
          head.acceleration == 0.0
              ? out.end_state().position + head.velocity * cruise + distance_to_rest(head.velocity, stop)
              : apply(advance(out.end_state(), 0.0, cruise), stop).position;
      cruise = std::max(cruise - (end_position - target_position) / head.velocity, 0.0);
    }
    return out.append(cruise, 0.0) && out.append(stop.t1, stop.jerk) && out.append(stop.t2, 0.0) &&
           out.append(stop.t3, -stop.jerk);
  };
  bool appended = append_all(c.t0_s, c.t1_s);
  if (appended && c.cruise_s == 0.0 && c.t2_s == 0.0) {
    const double miss = out.end_state().position - target_position;
    const double tolerance = 1e-13 * (1.0 + std::abs(target_position - from.position));
    double t0 = c.t0_s, t1 = c.t1_s;
    if (std::abs(miss) > tolerance && refine_head(from, jerk, target_position, L, tolerance, miss, t0, t1)) {
      out.truncate(first);
      appended = append_all(t0, t1);
    }
  }
  return appended && reaches(out, target_position, L);
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
  const VelocityChange c = velocity_change(s.velocity, a, 0.0, Lim(limits));
  if (!(out.append(c.t1, c.jerk) && out.append(c.t2, 0.0) && out.append(c.t3, -c.jerk))) {
    return {TrajectoryStatus::ErrorNoSolution, InvalidField::None};
  }
  return {};
}

namespace {

//! What stretching one joint's move to a longer duration needs, kept from its time-optimal
//! calculation. A stretched profile is the time-optimal change to a cruise velocity vp, a cruise at
//! vp, and the time-optimal change to rest. As |vp| falls to zero on the side where the stop alone
//! falls short of the target (`side`), the cruise grows without bound; towards larger |vp| the
//! cruise shrinks to nothing at the first no-cruise profile on that side (or at v_max). So every
//! duration from that profile's on is reachable, and the durations between the time-optimal one and
//! it (when they differ: the time-optimal profile is an early turn or on the other side) are the
//! blocked interval.
struct Stretch {
  JointState start{};            //!< after the braking segment, its acceleration clamped
  double brake_s = 0.0;          //!< [s] the braking segment
  double min_s = 0.0;            //!< [s] time-optimal duration, braking segment included
  double distance = 0.0;         //!< [m] from `start` to the target
  double side = 1.0;             //!< sign of the cruise velocity of stretched profiles
  double peak_end = 0.0;         //!< [m/s] largest |vp| of the stretchable branch
  double stretch_from_s = 0.0;   //!< [s] shortest stretched duration, braking segment included
  double stop_distance = 0.0;    //!< [m] of the time-optimal stop from `start`
};

CalculationResult time_optimal(const JointState& start, double target_position, const JointLimits& limits,
                               Profile& out, Stretch* stretch) noexcept {
  out.reset(start);
  if (const CalculationResult r = validate(start, limits); !r.ok()) return r;
  if (!finite(target_position)) return {TrajectoryStatus::ErrorInvalidInput, InvalidField::TargetPosition};
  const Lim L(limits);

  if (!append_brake(limits, out)) return {TrajectoryStatus::ErrorNoSolution, InvalidField::None};
  out.brake_phase_count = out.phase_count();
  JointState s = out.end_state();
  s.acceleration = std::clamp(s.acceleration, -limits.max_acceleration, limits.max_acceleration);

  const double d = target_position - s.position;
  const double brake_s = out.duration();
  if (stretch != nullptr) *stretch = {s, brake_s, brake_s, d, 1.0, 0.0, brake_s, 0.0};
  if (d == 0.0 && s.velocity == 0.0 && s.acceleration == 0.0) return {};
  // The time-optimal stop decides which way the target lies from where the joint would stop. The
  // fastest profile is then a UDDU of that direction (with every type solved, no other type was
  // faster in a million random problems of the property test), so those are solved first, and
  // every type of both directions only if none of them builds (never, in those problems).
  const std::size_t brake_phases = out.phase_count();
  // Fast path: a target far enough for a cruise at v_max in its direction. The changes to v_max and
  // back cover at least the time-optimal stop, so the target is on its side of the stop, and the
  // cruise is the fastest profile there (below). A stretch needs the other profiles too.
  double vel_passes_d = 0.0;  // the direction whose cruise at v_max was found to pass d, if any
  if (stretch == nullptr && d != 0.0) {
    const double sign = d > 0.0 ? 1.0 : -1.0;
    Candidate vel;
    VelocityChange tail;
    const bool found = vel_candidate(sign * s.velocity, sign * s.acceleration, sign * d, L, sign, vel, tail);
    if (found && build(vel, target_position, L, out, &tail)) return {};
    if (!found) vel_passes_d = sign;
    out.truncate(brake_phases);
  }
  const VelocityChange stop = velocity_change(s.velocity, s.acceleration, 0.0, L);
  const double stop_distance = apply({0.0, s.velocity, s.acceleration}, stop).position;
  const double side = d - stop_distance >= 0.0 ? 1.0 : -1.0;
  const VelocityChange rest_from_v_max = velocity_change(L.v_max, 0.0, 0.0, L);
  Candidates candidates;
  bool built = false;
  for (int pass = 0; pass < 2 && !built; ++pass) {
    candidates.count = 0;
    // A target where the stop ends: every type below meets it only at the end of its interval (a
    // ramp of zero length), where rounding may lose it. No move to rest is faster.
    if (std::abs(stop_distance - d) <= 1e-9) {
      candidates.add({stop.t1 + stop.t2 + stop.t3, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0, 0.0, false});
    }
    uddu_candidates(side * s.velocity, side * s.acceleration, side * d, L, side, candidates, side != vel_passes_d);
    // A stretch needs every no-cruise profile whose zero-acceleration velocity points to `side`
    // (UDDU that way, UDUD the other), not only the fastest.
    if (pass == 1 || stretch != nullptr) {
      udud_candidates(-side * s.velocity, -side * s.acceleration, -side * d, L, -side, candidates);
    }
    if (pass == 1) {
      uddu_candidates(-side * s.velocity, -side * s.acceleration, -side * d, L, -side, candidates);
      udud_candidates(side * s.velocity, side * s.acceleration, side * d, L, side, candidates);
    }

    // The fastest candidate that builds to the exact end state; a later one only if rounding made
    // the fastest miss it.
    for (std::size_t attempt = 0; attempt < candidates.count && !built; ++attempt) {
      Candidate* best = nullptr;
      for (std::size_t i = 0; i < candidates.count; ++i) {
        Candidate& c = candidates.items[i];
        if (!c.tried && (best == nullptr || c.duration_s < best->duration_s)) best = &c;
      }
      if (best == nullptr) break;
      best->tried = true;
      out.truncate(brake_phases);
      // A cruise at v_max ends with the change to rest from it, as on the fast path, so that both
      // build the same profile to the last bit.
      built = build(*best, target_position, L, out, best->cruise_s > 0.0 ? &rest_from_v_max : nullptr);
    }
  }
  if (!built) {
    out.truncate(brake_phases);
    return {TrajectoryStatus::ErrorNoSolution, InvalidField::None};
  }
  if (stretch != nullptr) {
    Stretch& st = *stretch;
    st.min_s = out.duration();
    st.side = side;
    st.stop_distance = stop_distance;
    st.peak_end = 0.0;
    st.stretch_from_s = std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < candidates.count; ++i) {
      const Candidate& c = candidates.items[i];
      const double vp = c.jerk_sign * c.peak_velocity;
      if (!(vp * st.side > 0.0)) continue;
      if (st.peak_end == 0.0 || std::abs(vp) < st.peak_end) {
        st.peak_end = std::abs(vp);
        st.stretch_from_s = brake_s + c.duration_s;
      }
    }
    st.stretch_from_s = std::max(st.stretch_from_s, st.min_s);
  }
  return {};
}

//! side * (position error) of the stretched profile with cruise velocity side * u lasting `after_s`
//! in all: negative at u = 0 (the stop falls short), positive at the branch end.
double stretch_error(const Stretch& st, const Lim& L, double u, double after_s) noexcept {
  const double vp = st.side * u;
  const VelocityChange c1 = velocity_change(st.start.velocity, st.start.acceleration, vp, L);
  const VelocityChange c2 = velocity_change(vp, 0.0, 0.0, L);
  const double changes_s = c1.t1 + c1.t2 + c1.t3 + c2.t1 + c2.t2 + c2.t3;
  const double distance =
      apply({0.0, st.start.velocity, st.start.acceleration}, c1).position + distance_to_rest(vp, c2);
  return st.side * (distance + vp * (after_s - changes_s) - st.distance);
}

//! Builds the stretched profile of duration_s into `out` (which holds the time-optimal one, whose
//! braking segment is kept): the cruise velocity by Illinois regula falsi with bisection steps on
//! [0, peak_end], the cruise taking the time the two changes leave.
CalculationResult stretch_to(const Stretch& st, double target_position, const JointLimits& lim, double duration_s,
                             Profile& out) noexcept {
  const Lim L(lim);
  const double after_s = duration_s - st.brake_s;
  double lo = 0.0, hi = st.peak_end;
  // The ends' errors in closed form: at u = 0 the profile is the stop; at the branch end the
  // no-cruise profile reaches the target, and the time left is cruised at the peak velocity.
  double f_lo = st.side * (st.stop_distance - st.distance);
  double f_hi = hi * (after_s - (st.stretch_from_s - st.brake_s));
  double u = f_lo >= 0.0 ? lo : hi;
  if (f_lo < 0.0 && f_hi > 0.0) {
    // Regula falsi with the Anderson-Björck correction (the retained end's value is scaled down
    // when the same end is kept twice), which converges superlinearly on this smooth error.
    int side = 0;
    for (int i = 0; i < 100; ++i) {
      u = (f_lo * hi - f_hi * lo) / (f_lo - f_hi);
      if (!(u > lo && u < hi)) u = lo + (hi - lo) / 2.0;
      if (u <= lo || u >= hi) break;
      const double f = stretch_error(st, L, u, after_s);
      // f is the end position error [m] of the profile that would be built: a hundredth of the
      // guaranteed 1e-8 is enough.
      if (std::abs(f) <= 1e-10) break;
      if (f < 0.0) {
        if (side == -1) {
          const double m = 1.0 - f / f_lo;
          f_hi *= m > 0.0 ? m : 0.5;
        }
        lo = u;
        f_lo = f;
        side = -1;
      } else {
        if (side == 1) {
          const double m = 1.0 - f / f_hi;
          f_lo *= m > 0.0 ? m : 0.5;
        }
        hi = u;
        f_hi = f;
        side = 1;
      }
      if (!(hi - lo > 4.0 * std::numeric_limits<double>::epsilon() * hi)) break;
    }
    if (!(u >= lo && u <= hi)) u = std::abs(f_lo) <= std::abs(f_hi) ? lo : hi;
  }
  const double vp = st.side * u;
  out.truncate(out.brake_phase_count);
  const VelocityChange c1 = velocity_change(st.start.velocity, st.start.acceleration, vp, L);
  if (!(out.append(c1.t1, c1.jerk) && out.append(c1.t2, 0.0) && out.append(c1.t3, -c1.jerk))) {
    return {TrajectoryStatus::ErrorNoSolution, InvalidField::None};
  }
  JointState peak = out.end_state();
  peak.acceleration = std::clamp(peak.acceleration, -lim.max_acceleration, lim.max_acceleration);
  const VelocityChange c2 = velocity_change(peak.velocity, peak.acceleration, 0.0, L);
  const double cruise_s = std::max(duration_s - out.duration() - (c2.t1 + c2.t2 + c2.t3), 0.0);
  if (!(out.append(cruise_s, 0.0) && out.append(c2.t1, c2.jerk) && out.append(c2.t2, 0.0) &&
        out.append(c2.t3, -c2.jerk))) {
    return {TrajectoryStatus::ErrorNoSolution, InvalidField::None};
  }
  if (!reaches(out, target_position, L) || !(std::abs(out.duration() - duration_s) <= 1e-9 * duration_s)) {
    return {TrajectoryStatus::ErrorNoSolution, InvalidField::None};
  }
  return {};
}

//! Relative margin within which a requested duration counts as the time-optimal one.
constexpr double kSameDuration = 1e-12;

//! Durations from the time-optimal one up to the stretched family's first (the blocked interval of
//! that family) are filled by the time-optimal profile under the jerk limit lowered to
//! lambda j_max: a profile within the true limits whose duration rises continuously from the
//! minimum as lambda falls (a lower limit never allows a faster profile). lambda stays above the
//! value at which the start, after the braking segment, would have to brake under the lowered
//! limit (its velocity at zero acceleration v + a|a|/(2 lambda j_max) beyond v_max), so the braking
//! rule never applies to it; 0 when no lambda < 1 qualifies.
double fill_lambda_floor(const Stretch& st, const JointLimits& lim) noexcept {
  const double a = st.start.acceleration, v = st.start.velocity;
  if (a == 0.0) return 1e-9;
  const double room = lim.max_velocity - (a > 0.0 ? v : -v);
  if (!(room > 0.0)) return 0.0;
  const double floor = a * a / (2.0 * lim.max_jerk * room) * (1.0 + 1e-9);
  return floor < 1.0 ? std::max(floor, 1e-9) : 0.0;
}

//! The time-optimal move from the state after the braking segment under jerk lambda j_max, into
//! `scratch`; its duration with the braking segment, or infinity if it failed.
double fill_duration(const Stretch& st, double target_position, const JointLimits& lim, double lambda,
                     Profile& scratch) noexcept {
  const JointLimits lowered{lim.max_velocity, lim.max_acceleration, lambda * lim.max_jerk};
  if (!time_optimal(st.start, target_position, lowered, scratch, nullptr).ok() || scratch.brake_phase_count != 0) {
    return std::numeric_limits<double>::infinity();
  }
  return st.brake_s + scratch.duration();
}

//! A family of filling profiles: an optional prefix phase of full jerk, then the time-optimal
//! profile from the state after it under the jerk limit lambda j_max, lambda in [floor, 1]; its
//! durations run continuously from `from.min_s` (lambda 1) to end_s (the floor).
struct FillFamily {
  Stretch from{};            //!< the state after the braking segment and the prefix; min_s at lambda 1
  double prefix_s = 0.0;     //!< [s]
  double prefix_jerk = 0.0;  //!< [/s³]
  double floor = 0.0;        //!< 0: the family is empty
  double end_s = 0.0;        //!< [s] the duration at the floor
};

//! A joint's two filling families. The first lowers the jerk from the start. A start whose velocity
//! at zero acceleration is at its limit (as after braking onto it) admits no lower jerk before its
//! acceleration is zero: the second takes full jerk to zero acceleration first, after which any
//! lower limit qualifies.
struct Fill {
  FillFamily first, second;
  [[nodiscard]] bool takes(double t) const noexcept {
    return (first.floor > 0.0 && t <= first.end_s) ||
           (second.floor > 0.0 && t >= second.from.min_s && t <= second.end_s);
  }
};

Fill make_fill(const Stretch& st, double target_position, const JointLimits& lim) noexcept {
  Fill f;
  Profile scratch;
  f.first.from = st;
  f.first.floor = fill_lambda_floor(st, lim);
  if (f.first.floor > 0.0) {
    f.first.end_s = fill_duration(st, target_position, lim, f.first.floor, scratch);
    if (!std::isfinite(f.first.end_s)) f.first.floor = 0.0;
  }
  const double a = st.start.acceleration;
  if (a != 0.0) {
    FillFamily& g = f.second;
    g.prefix_s = std::abs(a) / lim.max_jerk;
    g.prefix_jerk = a > 0.0 ? -lim.max_jerk : lim.max_jerk;
    g.from = st;
    g.from.start = advance(st.start, g.prefix_jerk, g.prefix_s);
    g.from.start.acceleration = 0.0;
    g.from.brake_s = st.brake_s + g.prefix_s;
    g.from.min_s = fill_duration(g.from, target_position, lim, 1.0, scratch);
    g.floor = fill_lambda_floor(g.from, lim);
    g.end_s = fill_duration(g.from, target_position, lim, g.floor, scratch);
    if (!std::isfinite(g.from.min_s) || !std::isfinite(g.end_s)) g.floor = 0.0;
  }
  return f;
}

//! Builds into `out` (whose braking segment is kept) the profile of duration_s of the family, which must
//! lie within its durations: lambda by Illinois regula falsi on the duration (at most 100 steps),
//! the profile accepted when its duration is duration_s to 1e-10.
CalculationResult fill_to(const FillFamily& fam, double target_position, const JointLimits& lim, double duration_s,
                          Profile& out) noexcept {
  const Stretch& st = fam.from;
  Profile scratch;
  double lo = fam.floor, hi = 1.0;
  double f_lo = fam.end_s - duration_s;    // >= 0
  double f_hi = st.min_s - duration_s;     // <= 0
  double best = f_lo < -f_hi ? lo : hi, best_error = std::min(std::abs(f_lo), std::abs(f_hi));
  int kept = 0;
  for (int i = 0; i < 100 && best_error > 1e-12 * duration_s; ++i) {
    double lambda = (f_lo * hi - f_hi * lo) / (f_lo - f_hi);
    if (!(lambda > lo && lambda < hi)) lambda = lo + (hi - lo) / 2.0;
    const double f = fill_duration(st, target_position, lim, lambda, scratch) - duration_s;
    if (!std::isfinite(f)) break;
    if (std::abs(f) < best_error) {
      best = lambda;
      best_error = std::abs(f);
    }
    if (f > 0.0) {
      if (kept == -1) f_hi /= 2.0;
      lo = lambda;
      f_lo = f;
      kept = -1;
    } else {
      if (kept == 1) f_lo /= 2.0;
      hi = lambda;
      f_hi = f;
      kept = 1;
    }
    if (!(hi - lo > 4.0 * std::numeric_limits<double>::epsilon() * hi)) break;
  }
  if (!(best_error <= 1e-10 * duration_s)) return {TrajectoryStatus::ErrorDuration, InvalidField::None};
  (void)fill_duration(st, target_position, lim, best, scratch);
  out.truncate(out.brake_phase_count);
  bool appended = out.append(fam.prefix_s, fam.prefix_jerk);
  for (std::size_t i = 0; i < scratch.phase_count(); ++i) {
    appended = appended && out.append(scratch.phase_duration(i), scratch.phase_jerk(i));
  }
  if (!appended || !reaches(out, target_position, Lim(lim)) ||
      !(std::abs(out.duration() - duration_s) <= 1e-9 * duration_s)) {
    return {TrajectoryStatus::ErrorNoSolution, InvalidField::None};
  }
  return {};
}

//! The filling profile of duration_s (minimum < duration_s < the stretched family's first), or
//! ErrorDuration when neither family takes it.
CalculationResult fill(const Fill& f, double target_position, const JointLimits& lim, double duration_s,
                       Profile& out) noexcept {
  if (f.first.floor > 0.0 && duration_s <= f.first.end_s) {
    return fill_to(f.first, target_position, lim, duration_s, out);
  }
  if (f.takes(duration_s)) return fill_to(f.second, target_position, lim, duration_s, out);
  return {TrajectoryStatus::ErrorDuration, InvalidField::None};
}

}  // namespace

CalculationResult calculate_time_optimal(const JointState& start, double target_position, const JointLimits& limits,
                                         Profile& out) noexcept {
  return time_optimal(start, target_position, limits, out, nullptr);
}

CalculationResult calculate_for_duration(const JointState& start, double target_position, const JointLimits& limits,
                                         double duration_s, Profile& out) noexcept {
  Stretch st;
  if (const CalculationResult r = time_optimal(start, target_position, limits, out, &st); !r.ok()) return r;
  if (!finite(duration_s)) return {TrajectoryStatus::ErrorInvalidInput, InvalidField::Duration};
  if (duration_s <= st.min_s * (1.0 + kSameDuration)) {
    if (duration_s < st.min_s * (1.0 - kSameDuration)) return {TrajectoryStatus::ErrorDuration, InvalidField::None};
    return {};
  }
  if (duration_s < st.stretch_from_s) {
    return fill(make_fill(st, target_position, limits), target_position, limits, duration_s, out);
  }
  return stretch_to(st, target_position, limits, duration_s, out);
}

SynchronizedResult calculate_synchronized(const JointState* start, const double* target_position,
                                          const JointLimits* limits, std::size_t joint_count, Profile* out) noexcept {
  SynchronizedResult result;
  if (joint_count == 0 || joint_count > kMaxSynchronizedJoints) {
    result.status = TrajectoryStatus::ErrorInvalidInput;
    result.field = InvalidField::JointCount;
    result.joint = joint_count;
    return result;
  }
  std::array<Stretch, kMaxSynchronizedJoints> st{};
  double duration_s = 0.0;
  for (std::size_t i = 0; i < joint_count; ++i) {
    const CalculationResult r = time_optimal(start[i], target_position[i], limits[i], out[i], &st[i]);
    if (!r.ok()) return {r.status, r.field, i, 0.0};
    duration_s = std::max(duration_s, st[i].min_s);
  }
  // The least duration no joint has blocked: the slowest joint's minimum, or else the least
  // stretched-profile start beyond it that every joint can take. A joint blocks the durations
  // between its filled ones (up to the lowered jerk's floor, computed only when asked) and its
  // stretched family's first.
  std::array<Fill, kMaxSynchronizedJoints> fills{};
  std::array<bool, kMaxSynchronizedJoints> fill_known{};
  const auto fill_of = [&](std::size_t i) -> const Fill& {
    if (!fill_known[i]) {
      fill_known[i] = true;
      fills[i] = make_fill(st[i], target_position[i], limits[i]);
    }
    return fills[i];
  };
  const auto takes = [&](double t) {
    for (std::size_t i = 0; i < joint_count; ++i) {
      if (t > st[i].min_s * (1.0 + kSameDuration) && t < st[i].stretch_from_s && !fill_of(i).takes(t)) return false;
    }
    return true;
  };
  if (!takes(duration_s)) {
    double best = std::numeric_limits<double>::infinity();
    // The candidates: where a joint's stretched family or its second filling family begins.
    for (std::size_t i = 0; i < joint_count; ++i) {
      const FillFamily& second = fill_of(i).second;
      for (const double t : {st[i].stretch_from_s, second.floor > 0.0 ? second.from.min_s : 0.0}) {
        if (t > duration_s && t < best && takes(t)) best = t;
      }
    }
    if (!std::isfinite(best)) return {TrajectoryStatus::ErrorNoSolution, InvalidField::None, joint_count, 0.0};
    duration_s = best;
  }
  for (std::size_t i = 0; i < joint_count; ++i) {
    if (duration_s <= st[i].min_s * (1.0 + kSameDuration)) continue;
    const CalculationResult r =
        duration_s < st[i].stretch_from_s
            ? fill(fill_of(i), target_position[i], limits[i], duration_s, out[i])
            : stretch_to(st[i], target_position[i], limits[i], duration_s, out[i]);
    if (!r.ok()) return {r.status, r.field, i, duration_s};
  }
  result.duration_s = duration_s;
  return result;
}

namespace {

//! The phase-synchronized move when the start allows it: every joint p_i(t) = p_i0 + d_i s(t)
//! for one path parameter s from 0 to 1, whose start velocity and acceleration are those of the
//! joint with the longest way divided by its distance; the limits of s are the least of every
//! joint's limits divided by its |d_i|. False (nothing written to the result) when some joint's
//! start is off that line, the path must brake, or a scaled profile misses its end state.
bool phase_synchronized(const JointState* start, const double* target_position, const JointLimits* limits,
                        std::size_t joint_count, Profile* out, SynchronizedResult& result) noexcept {
  std::size_t lead = 0;
  for (std::size_t i = 1; i < joint_count; ++i) {
    if (std::abs(target_position[i] - start[i].position) > std::abs(target_position[lead] - start[lead].position)) {
      lead = i;
    }
  }
  const double lead_distance = target_position[lead] - start[lead].position;
  if (lead_distance == 0.0) return false;
  const JointState path_start{0.0, start[lead].velocity / lead_distance, start[lead].acceleration / lead_distance};
  JointLimits path_limits{std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(),
                          std::numeric_limits<double>::infinity()};
  for (std::size_t i = 0; i < joint_count; ++i) {
    const double d = target_position[i] - start[i].position;
    // On the line: the joint's velocity and acceleration are d times the path's.
    if (!(std::abs(start[i].velocity - d * path_start.velocity) <= 1e-12 * limits[i].max_velocity) ||
        !(std::abs(start[i].acceleration - d * path_start.acceleration) <= 1e-12 * limits[i].max_acceleration)) {
      return false;
    }
    if (d == 0.0) continue;
    path_limits.max_velocity = std::min(path_limits.max_velocity, limits[i].max_velocity / std::abs(d));
    path_limits.max_acceleration = std::min(path_limits.max_acceleration, limits[i].max_acceleration / std::abs(d));
    path_limits.max_jerk = std::min(path_limits.max_jerk, limits[i].max_jerk / std::abs(d));
  }
  // A start that must brake is left to Time: each joint then follows its own braking rule, where
  // the path's would hold only the joint whose limit binds the path to it.
  Profile path;
  if (!calculate_time_optimal(path_start, 1.0, path_limits, path).ok() || path.brake_phase_count != 0) return false;
  for (std::size_t i = 0; i < joint_count; ++i) {
    const double d = target_position[i] - start[i].position;
    out[i].reset(start[i]);
    for (std::size_t k = 0; k < path.phase_count(); ++k) {
      // d times the path's limit is the joint's limit up to a rounding, which must not exceed it.
      const double jerk = std::clamp(d * path.phase_jerk(k), -limits[i].max_jerk, limits[i].max_jerk);
      if (!out[i].append(path.phase_duration(k), jerk)) return false;
    }
    out[i].brake_phase_count = path.brake_phase_count;
    if (!reaches(out[i], target_position[i], Lim(limits[i]))) return false;
  }
  result.duration_s = path.duration();
  result.phase_synchronized = true;
  return true;
}

}  // namespace

SynchronizedResult calculate_synchronized(const JointState* start, const double* target_position,
                                          const JointLimits* limits, std::size_t joint_count, Profile* out,
                                          Synchronization mode) noexcept {
  if (mode == Synchronization::Phase && joint_count >= 1 && joint_count <= kMaxSynchronizedJoints) {
    // Inputs are validated as for Time first, so that errors name the joint and field alike.
    SynchronizedResult result = calculate_synchronized(start, target_position, limits, joint_count, out);
    if (!result.ok()) return result;
    SynchronizedResult phase;
    if (phase_synchronized(start, target_position, limits, joint_count, out, phase)) return phase;
    return calculate_synchronized(start, target_position, limits, joint_count, out);
  }
  return calculate_synchronized(start, target_position, limits, joint_count, out);
}

}  // namespace mgc::guidance

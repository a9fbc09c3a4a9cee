// SPDX-License-Identifier: Apache-2.0
#pragma once

// Brute-force reference for the time-optimal duration of a rest-to-rest-style move, computed
// differently from the library: bisection on the duration T with a feasibility test. A target is
// reachable in T when it lies between the least and the greatest distance that can be covered in
// exactly T ending at rest; those extremes are found by a dense grid over the peak velocity, with
// the grid's feasibility boundaries bisected and its local extrema golden-section searched. The
// velocity changes are built by trying both jerk directions, not by the library's direction rule.
// Two families of profiles feed the extremes: a change to a peak velocity vp, a cruise at vp, a
// change to rest; and a short turn of the acceleration towards zero followed by a change to rest.

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

namespace mgc::test {

inline constexpr double kInf = std::numeric_limits<double>::infinity();

struct RefChange {
  double duration = 0.0;
  double distance = 0.0;
};

//! Fastest change from (v0, a0) to (vt, 0) with |a| <= a_max: the valid one of the two directions.
inline RefChange ref_change(double v0, double a0, double vt, double a_max, double j_max) {
  RefChange best{std::numeric_limits<double>::infinity(), 0.0};
  for (const double s : {1.0, -1.0}) {
    // Jerk s*j for t1, plateau t2 at s*ap, jerk -s*j for t3 = ap/j; dv = s*(ap^2 - a0^2/2)/j + plateau.
    const double peak_sq = (s * (vt - v0)) * j_max + a0 * a0 / 2.0;
    if (peak_sq < -1e-300) continue;
    double ap = std::sqrt(std::max(peak_sq, 0.0));
    double t2 = 0.0;
    if (ap > a_max) {
      ap = a_max;
      t2 = (s * (vt - v0) - (a_max * a_max - a0 * a0 / 2.0) / j_max) / a_max;
    }
    const double t1 = (ap - s * a0) / j_max;
    const double t3 = ap / j_max;
    if (t1 < -1e-12 * (1.0 + t3) || t2 < 0.0) continue;
    const double t1c = std::max(t1, 0.0);
    // Distance by the trapezoid-exact formulas per phase.
    double v = v0, a = a0, x = 0.0;
    const double j1 = s * j_max;
    x += v * t1c + a * t1c * t1c / 2.0 + j1 * t1c * t1c * t1c / 6.0;
    v += a * t1c + j1 * t1c * t1c / 2.0;
    a += j1 * t1c;
    x += v * t2 + a * t2 * t2 / 2.0;
    v += a * t2;
    x += v * t3 + a * t3 * t3 / 2.0 - j1 * t3 * t3 * t3 / 6.0;
    const double duration = t1c + t2 + t3;
    if (duration < best.duration) best = {duration, x};
  }
  return best;
}

struct RefProblem {
  double v0, a0, distance, v_max, a_max, j_max;

  RefChange member(double vp) const {
    const RefChange c1 = ref_change(v0, a0, vp, a_max, j_max);
    const RefChange c2 = ref_change(vp, 0.0, 0.0, a_max, j_max);
    return {c1.duration + c2.duration, c1.distance + c2.distance};
  }

  //! A profile that first jerks the acceleration towards zero for t1 in [0, |a0|/j_max] without
  //! reaching it, then changes to rest (no cruise). Its acceleration never passes through zero
  //! before the stop, so no peak velocity describes it. Distance by the per-phase formulas.
  RefChange turn_member(double t1) const {
    const double j = a0 < 0.0 ? j_max : -j_max;
    const double x1 = v0 * t1 + a0 * t1 * t1 / 2.0 + j * t1 * t1 * t1 / 6.0;
    const double v1 = v0 + a0 * t1 + j * t1 * t1 / 2.0;
    const double a1 = a0 + j * t1;
    const RefChange c = ref_change(v1, a1, 0.0, a_max, j_max);
    return {t1 + c.duration, x1 + c.distance};
  }

  //! The turn members stay within the velocity limits when the stop that follows the turn pushes
  //! the acceleration further from zero (the velocity then moves monotonically from v0 to 0): when
  //! ramping the acceleration to zero at once would leave a velocity of the sign opposite to a0.
  bool turn_family_valid() const {
    const double v_at_zero_a = v0 + a0 * std::abs(a0) / (2.0 * j_max);
    return a0 * v_at_zero_a < 0.0;
  }

  //! Largest value(x) over x in [lo, hi] among the feasible x (value sets ok): a dense grid plus
  //! the extra points, its feasibility boundaries bisected, its interior local maxima
  //! golden-section searched. The extra points are the cusps where the duration has a local
  //! minimum: just above that duration the feasible x form an island narrower than the grid.
  template <class Value>
  static double scan(double lo_x, double hi_x, int grid, std::vector<double> extra, const Value& value) {
    std::vector<double> xs;
    for (int i = 0; i <= grid; ++i) xs.push_back(lo_x + (hi_x - lo_x) * i / grid);
    for (const double x : extra) {
      if (x > lo_x && x < hi_x) xs.push_back(x);
    }
    std::sort(xs.begin(), xs.end());
    double best = -kInf;
    double prev_vp = 0.0, prev_val = 0.0, prev2_vp = 0.0, prev2_val = 0.0;
    bool prev_ok = false, prev2_ok = false;
    for (std::size_t i = 0; i < xs.size(); ++i) {
      const double vp = xs[i];
      bool ok = false;
      const double val = value(vp, ok);
      if (ok) best = std::max(best, val);
      if (i > 0 && ok != prev_ok) {  // a feasibility boundary: bisect to it
        double lo = prev_vp, hi = vp;
        for (int k = 0; k < 80; ++k) {
          const double mid = (lo + hi) / 2.0;
          if (mid <= lo || mid >= hi) break;
          bool mid_ok = false;
          value(mid, mid_ok);
          (mid_ok == prev_ok ? lo : hi) = mid;
        }
        bool lo_ok = false, hi_ok = false;
        const double vl = value(lo, lo_ok), vh = value(hi, hi_ok);
        if (lo_ok) best = std::max(best, vl);
        if (hi_ok) best = std::max(best, vh);
      }
      if (i > 1 && ok && prev_ok && prev2_ok && prev_val >= prev2_val && prev_val >= val) {
        double a = prev2_vp, b = vp;  // interior local maximum: golden section
        const double r = 0.6180339887498949;
        double c = b - r * (b - a), d = a + r * (b - a);
        bool okc = false, okd = false;
        double fc = value(c, okc), fd = value(d, okd);
        for (int k = 0; k < 100 && b - a > 1e-17 * (hi_x - lo_x); ++k) {
          if ((okc ? fc : -kInf) > (okd ? fd : -kInf)) {
            b = d; d = c; fd = fc; okd = okc; c = b - r * (b - a); fc = value(c, okc);
          } else {
            a = c; c = d; fc = fd; okc = okd; d = a + r * (b - a); fd = value(d, okd);
          }
        }
        if (okc) best = std::max(best, fc);
        if (okd) best = std::max(best, fd);
      }
      prev2_vp = prev_vp; prev2_val = prev_val; prev2_ok = prev_ok;
      prev_vp = vp; prev_val = val; prev_ok = ok;
    }
    return best;
  }

  //! Greatest (sign = 1) or, negated, least (sign = -1) distance ending at rest in exactly T (a
  //! profile ending early holds still at rest until T).
  double extreme(double T, double sign, int grid) const {
    const auto peak_value = [&](double vp, bool& ok) {
      const RefChange m = member(vp);
      ok = m.duration <= T;
      return sign * m.distance + std::max(0.0, sign * vp) * (T - m.duration);
    };
    // Cusps of the duration: the first change empty (vp at zero acceleration), the second empty.
    const double v_at_zero_a = v0 + a0 * std::abs(a0) / (2.0 * j_max);
    double best = scan(-v_max, v_max, grid, {v_at_zero_a, 0.0}, peak_value);
    if (turn_family_valid()) {
      const auto turn_value = [&](double t1, bool& ok) {
        const RefChange m = turn_member(t1);
        ok = m.duration <= T;
        return sign * m.distance;
      };
      best = std::max(best, scan(0.0, std::abs(a0) / j_max, grid, {}, turn_value));
    }
    return sign * best;
  }

  bool feasible(double T, int grid) const {
    return extreme(T, -1.0, grid) <= distance && distance <= extreme(T, 1.0, grid);
  }

  //! Least T with the target reachable, by bisection.
  double min_duration(int grid = 400) const {
    double hi = 1e-3;
    while (!feasible(hi, grid)) hi *= 2.0;
    double lo = 0.0;
    for (int k = 0; k < 200; ++k) {
      const double mid = (lo + hi) / 2.0;
      if (mid <= lo || mid >= hi) break;
      (feasible(mid, grid) ? hi : lo) = mid;
    }
    return hi;
  }
};

}  // namespace mgc::test

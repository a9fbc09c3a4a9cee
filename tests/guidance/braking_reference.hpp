// SPDX-License-Identifier: Apache-2.0
#pragma once

// Brute-force reference for starts that must brake (docs/trajectory.md, "Starts that must brake"):
// the earliest instant t_in from which the velocity can stay within ±v_max, and the least duration
// from the state there. Written for the tests, independently of the library's closed form:
// - t_in is searched over jerk sequences of both signs: full jerk (the acceleration held at ±a_max
//   once there), switched to full opposite jerk at a time taken from a grid, bisected where the
//   entry time jumps, or never switched; each path is scanned on a grid, with bisection, for its
//   first state in the viable set (|v| <= v_max and the velocity at zero acceleration
//   v + a|a|/(2 j_max) within ±v_max, from which the jerk towards zero acceleration keeps it inside).
// - the rest is searched over feasible profiles to rest: a change to a peak velocity vp and a change
//   to rest, with vp on a grid over [-v_max, v_max] and the distance's crossings of the target
//   bisected (no cruise), or vp = ±v_max with a cruise; and a turn of the acceleration towards zero
//   followed by a change to rest, its crossings bisected. Every profile it returns is feasible,
//   so a valid profile shorter than its answer would show it incomplete, and one longer shows the
//   solver is not time-optimal.

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <vector>

#include "reference.hpp"

namespace mgc::test::braking {

struct State {
  double p = 0.0, v = 0.0, a = 0.0;
};

struct Limits {
  double v_max = 1.0, a_max = 1.0, j_max = 1.0;
};

inline State integrate(const State& s, double j, double t) {
  return {s.p + s.v * t + s.a * t * t / 2.0 + j * t * t * t / 6.0, s.v + s.a * t + j * t * t / 2.0, s.a + j * t};
}

//! From s the velocity can stay within ±v_max forever (to 1e-12 relative).
inline bool viable(const State& s, const Limits& l) {
  const double v_az = s.v + s.a * std::abs(s.a) / (2.0 * l.j_max);
  const double lim = l.v_max * (1.0 + 1e-12);
  return std::abs(s.v) <= lim && std::abs(v_az) <= lim;
}

//! Full jerk sigma*j_max (the acceleration held at sigma*a_max once there) until switch_s, then
//! full jerk -sigma*j_max (held at -sigma*a_max), as up to four phases of constant jerk.
struct Path {
  std::array<double, 4> duration{};
  std::array<double, 4> jerk{};
  State start;

  Path(const State& s0, const Limits& l, double sigma, double switch_s) : start(s0) {
    const double to_cap = std::max((l.a_max - sigma * s0.a) / l.j_max, 0.0);
    const double t1 = std::min(switch_s, to_cap);
    duration[0] = t1;
    jerk[0] = sigma * l.j_max;
    duration[1] = std::max(switch_s - to_cap, 0.0);
    jerk[1] = 0.0;
    const double a_switch = std::isfinite(switch_s) ? s0.a + sigma * l.j_max * t1 : 0.0;
    duration[2] = std::isfinite(switch_s) ? std::max((sigma * a_switch + l.a_max) / l.j_max, 0.0) : 0.0;
    jerk[2] = -sigma * l.j_max;
    duration[3] = kInf;
    jerk[3] = 0.0;
  }

  State at(double t) const {
    State s = start;
    for (std::size_t i = 0; i < 4; ++i) {
      if (t <= duration[i]) return integrate(s, jerk[i], t);
      s = integrate(s, jerk[i], duration[i]);
      t -= duration[i];
    }
    return s;
  }
};

//! First t in [from, horizon] with path.at(t) viable (grid of `grid` steps, then bisection); kInf if none.
inline double first_entry(const Path& path, const Limits& l, double from, double horizon, int grid) {
  if (viable(path.at(from), l)) return from;
  double prev = from;
  for (int i = 1; i <= grid; ++i) {
    const double t = from + (horizon - from) * i / grid;
    if (viable(path.at(t), l)) {
      double lo = prev, hi = t;
      for (int k = 0; k < 200 && hi - lo > 0.0; ++k) {
        const double mid = lo + (hi - lo) / 2.0;
        if (mid <= lo || mid >= hi) break;
        (viable(path.at(mid), l) ? hi : lo) = mid;
      }
      return hi;
    }
    prev = t;
  }
  return kInf;
}

struct Entry {
  double t_s = kInf;  //!< earliest instant from which the velocity can stay within
  State state;        //!< the state then
};

//! The earliest entry into the viable set over the searched paths.
inline Entry earliest_entry(const State& s0, const Limits& l, int grid = 64) {
  if (viable(s0, l)) return {0.0, s0};
  const double horizon = 2.0 * (4.0 * l.a_max / l.j_max + (std::abs(s0.v) + 3.0 * l.v_max + l.a_max * l.a_max / l.j_max) / l.a_max);
  Entry best;
  for (const double sigma : {1.0, -1.0}) {
    const Path never(s0, l, sigma, kInf);
    const double t_never = first_entry(never, l, 0.0, horizon, 4 * grid);
    if (t_never < best.t_s) best = {t_never, never.at(t_never)};
    // Switching after the unswitched path's entry changes nothing before it. A switched path is
    // scanned from the start: it may already have entered before its switch (for less than a
    // grid step, which the scan of the unswitched path can miss, while the switch keeps it in).
    const double last_switch = std::min(horizon, t_never);
    const auto entry_for = [&](double sw) {
      const Path p(s0, l, sigma, sw);
      return first_entry(p, l, 0.0, sw + horizon, grid);
    };
    double best_sw = -1.0, best_t = kInf;
    for (int i = 0; i <= grid; ++i) {
      const double sw = last_switch * i / grid;
      const double t = entry_for(sw);
      if (t < best_t) {
        best_t = t;
        best_sw = sw;
      }
    }
    // The grid can miss the narrow range of switches after which the path stays within (when the
    // velocity at zero acceleration is far beyond v_max). The velocity where the switched path's
    // acceleration next passes zero rises with the switch time: bisect the switch to where it is
    // sigma*v_max (the latest switch that does not overshoot the other limit) and scan its entry.
    const auto peak_after = [&](double sw) {
      const Path p(s0, l, sigma, sw);
      const State at_switch = p.at(sw);
      const double to_zero = sigma * at_switch.a > 0.0 ? std::abs(at_switch.a) / l.j_max : 0.0;
      return sigma * p.at(sw + to_zero).v;
    };
    if (peak_after(0.0) <= l.v_max && peak_after(last_switch) > l.v_max) {
      double lo_sw = 0.0, hi_sw = last_switch;
      for (int k = 0; k < 200; ++k) {
        const double mid = lo_sw + (hi_sw - lo_sw) / 2.0;
        if (mid <= lo_sw || mid >= hi_sw) break;
        (peak_after(mid) <= l.v_max ? lo_sw : hi_sw) = mid;
      }
      // Its path stays within from its entry until its acceleration has passed zero: a window
      // that can be short against the horizon, so a finer scan.
      const double t = first_entry(Path(s0, l, sigma, lo_sw), l, 0.0, lo_sw + horizon, 64 * grid);
      if (t < best_t) {
        best_t = t;
        best_sw = lo_sw;
      }
    }
    if (best_sw >= 0.0 && best_t < best.t_s) best = {best_t, Path(s0, l, sigma, best_sw).at(best_t)};
  }
  return best;
}

//! Least duration found from a viable state s to rest at `target` within the limits.
inline double rest_duration(const State& s, double target, const Limits& l, int grid = 256) {
  const double d = target - s.p;
  const RefProblem prob{s.v, s.a, d, l.v_max, l.a_max, l.j_max};
  double best = kInf;
  // Peak-velocity family: the distance's crossings of d (no cruise), bisected. The grid holds the
  // cusps of the distance too (the first change empty at the velocity at zero acceleration, the
  // second at zero), next to which two crossings can lie closer than a grid step.
  std::vector<double> vps;
  for (int i = 0; i <= grid; ++i) vps.push_back(-l.v_max + 2.0 * l.v_max * i / grid);
  for (const double cusp : {s.v + s.a * std::abs(s.a) / (2.0 * l.j_max), 0.0}) {
    if (std::abs(cusp) < l.v_max) vps.push_back(cusp);
  }
  std::sort(vps.begin(), vps.end());
  const auto miss = [&](double vp) { return prob.member(vp).distance - d; };
  double prev_vp = vps[0], prev_f = miss(prev_vp);
  for (std::size_t i = 1; i < vps.size(); ++i) {
    const double vp = vps[i];
    const double f = miss(vp);
    if (std::isfinite(f) && std::isfinite(prev_f) && (f == 0.0 || (f < 0.0) != (prev_f < 0.0))) {
      double lo = prev_vp, hi = vp, f_lo = prev_f;
      for (int k = 0; k < 200; ++k) {
        const double mid = lo + (hi - lo) / 2.0;
        if (mid <= lo || mid >= hi) break;
        const double fm = miss(mid);
        if ((fm < 0.0) == (f_lo < 0.0)) {
          lo = mid;
          f_lo = fm;
        } else {
          hi = mid;
        }
      }
      for (const double x : {lo, hi}) {
        const RefChange m = prob.member(x);
        if (std::abs(m.distance - d) <= 1e-9 * (1.0 + std::abs(d))) best = std::min(best, m.duration);
      }
    }
    prev_vp = vp;
    prev_f = f;
  }
  // A cruise at ±v_max.
  for (const double vp : {l.v_max, -l.v_max}) {
    const RefChange m = prob.member(vp);
    const double cruise = (d - m.distance) / vp;
    if (cruise >= 0.0) best = std::min(best, m.duration + cruise);
  }
  // The turn family.
  if (prob.turn_family_valid()) {
    const double t_end = std::abs(s.a) / l.j_max;
    const auto turn_miss = [&](double t1) { return prob.turn_member(t1).distance - d; };
    double prev_t = 0.0, prev_g = turn_miss(0.0);
    for (int i = 1; i <= grid; ++i) {
      const double t1 = t_end * i / grid;
      const double g = turn_miss(t1);
      if (g == 0.0 || (g < 0.0) != (prev_g < 0.0)) {
        double lo = prev_t, hi = t1, g_lo = prev_g;
        for (int k = 0; k < 200; ++k) {
          const double mid = lo + (hi - lo) / 2.0;
          if (mid <= lo || mid >= hi) break;
          const double gm = turn_miss(mid);
          if ((gm < 0.0) == (g_lo < 0.0)) {
            lo = mid;
            g_lo = gm;
          } else {
            hi = mid;
          }
        }
        for (const double x : {lo, hi}) {
          const RefChange m = prob.turn_member(x);
          if (std::abs(m.distance - d) <= 1e-9 * (1.0 + std::abs(d))) best = std::min(best, m.duration);
        }
      }
      prev_t = t1;
      prev_g = g;
    }
  }
  return best;
}

}  // namespace mgc::test::braking

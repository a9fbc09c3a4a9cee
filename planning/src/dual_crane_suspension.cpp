// SPDX-License-Identifier: Apache-2.0
// The closed chain of seed 004 (§2 of note 004): equilibrium as the lowest girder centre.
#include <algorithm>
#include <cmath>
#include <limits>

#include "mgc/planning/dual_crane.hpp"

namespace mgc::planning {
namespace {

// The chain in the vertical plane through both tips: x along tip 1 -> tip 2 horizontally.
struct Plane {
  double x1 = 0.0, z1 = 0.0, x2 = 0.0, z2 = 0.0;
  double l1 = 0.0, l2 = 0.0, girder = 0.0;
};

// One closed chain for a given cable-1 tilt.
struct Closure {
  bool valid = false;
  double tilt_2 = 0.0;
  double girder_tilt = 0.0;
  double centre_z = 0.0;  //!< girder centre height [m]
};

// Value standing for "no closed chain here" in the minimiser: large, but finite so that Brent's
// parabola arithmetic stays finite.
constexpr double kNoChain = 1e30;
// Coarse samples of cable 1's tilt over the range: a minimum is bracketed to within 1/10 of the
// limit before Brent refines it.
constexpr int kScanSamples = 21;
constexpr double kTiltTolerance_rad = 1e-9;

Closure close_chain(const Plane& p, double tilt_1) noexcept {
  std::array<double, 2> sines{};
  const int roots = appendix_cable_2_sines(p.x1, p.z1, p.x2, p.z2, p.l1, p.l2, p.girder, tilt_1, sines);
  const double s1 = std::sin(tilt_1);
  const double c1 = std::cos(tilt_1);
  const double dx = p.x1 - p.x2;
  const double dz = p.z1 - p.z2;
  const double a = 2.0 * dx * p.l2 + 2.0 * p.l1 * p.l2 * s1;
  const double b = 2.0 * dz * p.l2 - 2.0 * p.l1 * p.l2 * c1;
  const double c = dx * dx + dz * dz + p.l1 * p.l1 + p.l2 * p.l2 + 2.0 * dx * p.l1 * s1 - 2.0 * dz * p.l1 * c1 -
                   p.girder * p.girder;
  const double scale = std::abs(a) + std::abs(b) + std::abs(c);
  Closure best;
  for (int r = 0; r < roots; ++r) {
    const double s2 = sines[static_cast<std::size_t>(r)];
    // The cable hangs below its tip (cos > 0); squaring (A5) admits the mirror image, which
    // fails (A1).
    const double c2 = std::sqrt(std::max(0.0, 1.0 - s2 * s2));
    if (std::abs(a * s2 + b * c2 + c) > 1e-9 * scale) continue;
    const double girder_cos = (p.x2 - p.x1 - p.l1 * s1 - p.l2 * s2) / p.girder;
    const double girder_sin = (p.z2 - p.z1 + p.l1 * c1 - p.l2 * c2) / p.girder;
    // A girder folded back under crane 1 closes the loop too, but is not the lift.
    if (girder_cos <= 0.0) continue;
    // A uniform girder hung at its ends: its centre is halfway between the anchors.
    const double centre_z = 0.5 * ((p.z1 - p.l1 * c1) + (p.z2 - p.l2 * c2));
    if (!best.valid || centre_z < best.centre_z) {
      best.valid = true;
      best.tilt_2 = std::atan2(s2, c2);
      best.girder_tilt = std::atan2(girder_sin, girder_cos);
      best.centre_z = centre_z;
    }
  }
  return best;
}

double centre_height(const Plane& p, double tilt_1) noexcept {
  const Closure c = close_chain(p, tilt_1);
  return c.valid ? c.centre_z : kNoChain;
}

// Brent's minimiser on [lo, hi] (golden sections with parabolic steps; Brent 1973, ch. 5),
// without derivatives.
double brent_minimum(const Plane& p, double lo, double hi) noexcept {
  constexpr double kGolden = 0.3819660112501051;  // (3 - sqrt 5) / 2
  constexpr int kMaxIterations = 100;
  double x = lo + kGolden * (hi - lo);
  double w = x;
  double v = x;
  double fx = centre_height(p, x);
  double fw = fx;
  double fv = fx;
  double d = 0.0;
  double e = 0.0;
  for (int it = 0; it < kMaxIterations; ++it) {
    const double mid = 0.5 * (lo + hi);
    const double tol1 = kTiltTolerance_rad + 1e-10 * std::abs(x);
    const double tol2 = 2.0 * tol1;
    if (std::abs(x - mid) <= tol2 - 0.5 * (hi - lo)) break;
    bool golden = true;
    if (std::abs(e) > tol1) {
      // Parabola through (v, fv), (w, fw), (x, fx).
      double r = (x - w) * (fx - fv);
      double q = (x - v) * (fx - fw);
      double step = (x - v) * q - (x - w) * r;
      q = 2.0 * (q - r);
      if (q > 0.0) step = -step;
      q = std::abs(q);
      const double e_prev = e;
      e = d;
      if (std::abs(step) < std::abs(0.5 * q * e_prev) && step > q * (lo - x) && step < q * (hi - x)) {
        d = step / q;
        const double u = x + d;
        if (u - lo < tol2 || hi - u < tol2) d = mid >= x ? tol1 : -tol1;
        golden = false;
      }
    }
    if (golden) {
      e = (x >= mid ? lo : hi) - x;
      d = kGolden * e;
    }
    const double u = std::abs(d) >= tol1 ? x + d : x + (d > 0.0 ? tol1 : -tol1);
    const double fu = centre_height(p, u);
    if (fu <= fx) {
      (u >= x ? lo : hi) = x;
      v = w;
      fv = fw;
      w = x;
      fw = fx;
      x = u;
      fx = fu;
    } else {
      (u < x ? lo : hi) = u;
      if (fu <= fw || w == x) {
        v = w;
        fv = fw;
        w = u;
        fw = fu;
      } else if (fu <= fv || v == x || v == w) {
        v = u;
        fv = fu;
      }
    }
  }
  return x;
}

}  // namespace

int appendix_cable_2_sines(double x1_m, double z1_m, double x2_m, double z2_m, double cable_1_m, double cable_2_m,
                           double girder_length_m, double tilt_1_rad, std::array<double, 2>& sines) noexcept {
  const double s1 = std::sin(tilt_1_rad);
  const double c1 = std::cos(tilt_1_rad);
  const double dx = x1_m - x2_m;
  const double dz = z1_m - z2_m;
  // (A2)-(A4); (A4) with the - l_obj^2 the paper drops.
  const double a = 2.0 * dx * cable_2_m + 2.0 * cable_1_m * cable_2_m * s1;
  const double b = 2.0 * dz * cable_2_m - 2.0 * cable_1_m * cable_2_m * c1;
  const double c = dx * dx + dz * dz + cable_1_m * cable_1_m + cable_2_m * cable_2_m + 2.0 * dx * cable_1_m * s1 -
                   2.0 * dz * cable_1_m * c1 - girder_length_m * girder_length_m;
  // (A5) corrected: (A^2 + B^2) s^2 + 2 A C s + (C^2 - B^2) = 0, whose discriminant / 4 is
  // B^2 (A^2 + B^2 - C^2).
  const double ab = a * a + b * b;
  if (!(ab > 0.0)) return 0;
  const double reach = ab - c * c;
  if (reach < 0.0) return 0;
  const double root = std::abs(b) * std::sqrt(reach);
  int n = 0;
  for (const double s : {(-a * c - root) / ab, (-a * c + root) / ab}) {
    if (std::abs(s) <= 1.0) sines[static_cast<std::size_t>(n++)] = s;
  }
  return n;
}

Suspension solve_suspension(const SuspensionInput& in) noexcept {
  Suspension out;
  const Eigen::Vector2d horizontal = (in.tip_2_m - in.tip_1_m).head<2>();
  const double span_m = horizontal.norm();
  // Tips one above the other span no vertical plane; the girder would hang vertically anyway.
  if (!(span_m > 1e-9) || !(in.max_cable_tilt_rad > 0.0)) {
    out.status = SuspensionStatus::TipsAligned;
    return out;
  }
  const Eigen::Vector2d u = horizontal / span_m;
  Plane p;
  p.x1 = 0.0;
  p.z1 = in.tip_1_m.z();
  p.x2 = span_m;
  p.z2 = in.tip_2_m.z();
  p.l1 = in.cable_1_m;
  p.l2 = in.cable_2_m;
  p.girder = in.girder_length_m;

  const double limit = in.max_cable_tilt_rad;
  const double spacing = 2.0 * limit / (kScanSamples - 1);
  int best = -1;
  double best_z = kNoChain;
  for (int k = 0; k < kScanSamples; ++k) {
    const double z = centre_height(p, -limit + k * spacing);
    if (z < best_z) {
      best_z = z;
      best = k;
    }
  }
  if (best < 0) {
    out.status = SuspensionStatus::NoEquilibrium;
    return out;
  }
  const double lo = -limit + std::max(0, best - 1) * spacing;
  const double hi = -limit + std::min(kScanSamples - 1, best + 1) * spacing;
  double tilt_1 = brent_minimum(p, lo, hi);
  // Brent never evaluates the bracket's ends; a minimum there is the range's edge.
  if (centre_height(p, tilt_1) > best_z) tilt_1 = -limit + best * spacing;
  if (std::abs(tilt_1) >= limit - 1e3 * kTiltTolerance_rad) {
    out.status = SuspensionStatus::NoEquilibrium;
    out.boundary_tilt_rad = tilt_1;
    return out;
  }
  const Closure c = close_chain(p, tilt_1);
  if (!c.valid) {
    out.status = SuspensionStatus::NoEquilibrium;
    out.boundary_tilt_rad = tilt_1;
    return out;
  }
  out.status = SuspensionStatus::Ok;
  out.cable_tilt_1_rad = tilt_1;
  out.cable_tilt_2_rad = c.tilt_2;
  out.girder_tilt_rad = c.girder_tilt;
  const Eigen::Vector3d toward(u.x(), u.y(), 0.0);
  out.anchor_1_m = in.tip_1_m + in.cable_1_m * (std::sin(tilt_1) * toward - std::cos(tilt_1) * Eigen::Vector3d::UnitZ());
  out.anchor_2_m = in.tip_2_m - in.cable_2_m * (std::sin(c.tilt_2) * toward + std::cos(c.tilt_2) * Eigen::Vector3d::UnitZ());
  // Vertical balance, |F1| cos t1 + |F2| cos t2 = m g, and torque about the centre,
  // |F1| cos(g - t1) = |F2| cos(g + t2): well conditioned with both cables near vertical, where
  // the horizontal balance (6) degenerates to 0 = 0.
  const double ratio = std::cos(c.girder_tilt + c.tilt_2) / std::cos(c.girder_tilt - tilt_1);
  out.tension_share_2 = 1.0 / (std::cos(c.tilt_2) + std::cos(tilt_1) * ratio);
  out.tension_share_1 = ratio * out.tension_share_2;
  return out;
}

}  // namespace mgc::planning

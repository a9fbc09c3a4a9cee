// SPDX-License-Identifier: Apache-2.0
#pragma once

// The true clearance between the machines of a site (docs/site.md): per pair of machines, every
// body of one (load and rigging included) against every body of the other, undilated, sized and
// posed from the simulators' true joints. The site rig's referee in stepped time and mgc-sim's
// over the machines of one process share it.

#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "mgc/planning/site.hpp"
#include "mgc/sim/simulator.hpp"

namespace mgc::sim {

//! The least true clearance of two machines seen so far.
struct SitePairTruth {
  std::int32_t machine_a = 0;
  std::int32_t machine_b = 0;
  double least_m = 1e9;
  double least_t_s = 0.0;
  //! The bodies nearest each other at the least: machine a's and machine b's (model order); -1
  //! before the first sample.
  int least_body_a = -1;
  int least_body_b = -1;
  std::uint64_t samples = 0;
  std::uint64_t samples_in_contact = 0;
  std::uint64_t samples_below_margin = 0;  //!< clearance below SitePairReferee's margin
};

class SitePairReferee {
 public:
  //! Builds, for every pair of the site's machines, a world of machine a's model (its first lift's
  //! load and rigging) with machine b's bodies as dynamic obstacles. Allocates. margin_m: a sample
  //! below it counts as close (0.5 m, the controller's default stop margin). Throws
  //! std::invalid_argument for a machine whose model cannot be built.
  explicit SitePairReferee(const planning::Site& site, double margin_m = 0.5);
  ~SitePairReferee();
  SitePairReferee(const SitePairReferee&) = delete;
  SitePairReferee& operator=(const SitePairReferee&) = delete;

  //! Measures every pair at simulation time t_s from the machines' true states, one per machine
  //! in site order (unwrapped joints). No allocation.
  void measure(double t_s, std::span<const TrueState* const> truths) noexcept;

  [[nodiscard]] const std::vector<SitePairTruth>& pairs() const noexcept { return pairs_; }
  //! The pair whose least clearance is the least, or null on a site of one machine.
  [[nodiscard]] const SitePairTruth* least_pair() const noexcept;
  //! The least of every pair's least clearance; +inf on a site of one machine. [m]
  [[nodiscard]] double least_m() const noexcept;
  [[nodiscard]] double margin_m() const noexcept { return margin_m_; }
  //! measure() calls, and those in which some pair was in contact or below the margin.
  [[nodiscard]] std::uint64_t samples() const noexcept { return samples_; }
  [[nodiscard]] std::uint64_t samples_in_contact() const noexcept { return samples_in_contact_; }
  [[nodiscard]] std::uint64_t samples_below_margin() const noexcept { return samples_below_margin_; }

  //! e.g. "least clearance 1.66 m at 42.10 s (machine 2 load to machine 1 carrier), 0 of 2400
  //! samples in contact, 3 below 0.50 m"; with more than two machines, the least pair's, then
  //! "; per pair: 1-2 1.66 m, 1-3 ...". Allocates.
  [[nodiscard]] std::string summary_line() const;

 private:
  struct PairWorld;
  std::vector<std::int32_t> ids_;
  std::vector<std::unique_ptr<PairWorld>> worlds_;
  std::vector<SitePairTruth> pairs_;
  double margin_m_;
  std::uint64_t samples_ = 0;
  std::uint64_t samples_in_contact_ = 0;
  std::uint64_t samples_below_margin_ = 0;
};

}  // namespace mgc::sim

// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <Eigen/Geometry>

#include <array>
#include <cstddef>
#include <cstdint>

#include "mgc/hal/hal.hpp"
#include "mgc/planning/scenario.hpp"

//! The pose of a moving obstacle (a second crane, a truck) from the UWB tags fixed to it: a
//! weighted rigid fit of the tags' known layout to their fixes, behind an outlier gate against the
//! predicted pose and, with three tags or more, against the fit's own residuals. An obstacle that
//! stands still is posed by the average of its fits since it stopped, behind a stillness test that
//! a start of motion breaks. docs/control-loop.md §Obstacles from UWB tags.
namespace mgc::firmware {

inline constexpr std::size_t kMaxTagsPerObstacle = 8;

struct TrackerConfig {
  double gate_sigmas = 3.0;           //!< a fix farther than this many of its sigmas is an outlier [-]
  double min_gate_m = 0.5;            //!< never gate tighter than this [m]
  double max_speed_m_s = 5.0;         //!< how fast a tag can move between fixes (site traffic) [m/s]
  double unknown_sigma_m = 1.5;       //!< sigma used for quality 15 ("worse or unknown") [m]
  std::int64_t lost_after_us = 1'000'000;  //!< no accepted fix for this long: the pose is unknown [µs]
  //! Tags are fixed one after another (TDMA), so a cycle rarely sees all of them: each fit uses
  //! every tag's latest accepted fix younger than this. Two 10 Hz periods by default. [µs]
  std::int64_t fusion_window_us = 200'000;
  //! Stillness test, at every tag's place in plan view: the mean of the fits of the last
  //! still_window_us against the mean of the still period's fits before them, and the newest fit
  //! against the mean of all. A difference beyond still_gate_sigmas × its 1-sigma (from the fixes'
  //! own sigmas) is motion: a new still period starts from the newest fit. The average is the pose
  //! once the period spans two windows. docs/control-loop.md. [µs | -]
  std::int64_t still_window_us = 600'000;
  double still_gate_sigmas = 4.0;
};

//! Fits kept for the stillness test's recent window: a fresh fix every 10 ms cycle for 0.64 s. [-]
inline constexpr std::size_t kStillRing = 64;

struct TrackerCounters {
  std::uint64_t updates = 0;          //!< cycles with at least one accepted fix [-]
  std::uint64_t fixes_used = 0;       //!< [-]
  std::uint64_t outliers = 0;         //!< fixes rejected by a gate [-]
  std::uint64_t motion_starts = 0;    //!< stillness tests that found motion [-]
};

//! Tracks one dynamic obstacle. Construction copies the tag layout (start-up); update() is RT-safe.
class ObstacleTracker {
 public:
  //! Throws std::invalid_argument for an obstacle with no tags or more than kMaxTagsPerObstacle.
  ObstacleTracker(const planning::DynamicObstacleSpec& spec, const TrackerConfig& config);

  //! Takes this cycle's fresh fixes (TagReading::updated) of the obstacle's tags, gates them
  //! against the current pose, and refits from every tag's latest fix in the fusion window. The
  //! first pose (and the first after the track was lost) needs two tags apart in plan view (the yaw
  //! must be observable) unless the obstacle
  //! has only one tag, whose yaw is then the scenario's first key. Returns true when the pose was
  //! updated. RT-safe.
  bool update(const hal::SensorSnapshot& snapshot, std::int64_t now_us) noexcept;

  //! A pose has been fitted and the last accepted fix is not older than lost_after_us.
  [[nodiscard]] bool valid(std::int64_t now_us) const noexcept {
    return have_pose_ && now_us - last_update_us_ <= config_.lost_after_us;
  }
  //! The obstacle frame in the site frame (position and yaw about z, as the scenario scripts it).
  [[nodiscard]] Eigen::Isometry3d pose() const noexcept;
  [[nodiscard]] double yaw_rad() const noexcept { return yaw_rad_; }
  [[nodiscard]] const Eigen::Vector3d& position_m() const noexcept { return position_m_; }
  //! The pose is the average of the fits since the obstacle was last seen to move: it has stood
  //! still for two still windows and the stillness test holds.
  [[nodiscard]] bool still() const noexcept { return still_; }
  //! 1-sigma of the position: of the fixes used in the last update, or while still() of every
  //! fix averaged since the obstacle stopped [m].
  [[nodiscard]] double position_sigma_m() const noexcept { return sigma_m_; }
  [[nodiscard]] std::int64_t last_update_us() const noexcept { return last_update_us_; }
  [[nodiscard]] const TrackerCounters& counters() const noexcept { return counters_; }

 private:
  struct Fix {
    Eigen::Vector3d local_m;
    Eigen::Vector3d world_m;
    double sigma_m;
    bool used;
  };
  struct Latest {
    Eigen::Vector3d world_m = Eigen::Vector3d::Zero();
    double sigma_m = 0.0;
    std::int64_t t_us = 0;
    bool have = false;
  };
  //! Weighted rigid fit (yaw about z and a translation) of the used fixes; with one fix the yaw is
  //! kept. Returns false when no fix is used.
  bool fit(std::size_t count, double& yaw_rad, Eigen::Vector3d& position_m) const noexcept;
  //! Adds this update's fit to the still average and runs the stillness test; sets still_ and the
  //! pose to publish. fresh_inv_var: sum of 1/sigma^2 of this update's fresh fixes.
  void average(std::int64_t now_us, double& yaw_rad, Eigen::Vector3d& position_m, double& sigma_m, double fresh_inv_var) noexcept;

  //! Sums of fits: positions, yaws relative to yaw_ref_rad_, 1/sigma^2 of their fresh fixes.
  struct FitSum {
    Eigen::Vector3d position_m = Eigen::Vector3d::Zero();
    double yaw_rad = 0.0;
    double inv_var = 0.0;
    std::size_t count = 0;
  };
  struct StillFit {
    std::int64_t t_us = 0;
    Eigen::Vector3d position_m = Eigen::Vector3d::Zero();
    double yaw_rad = 0.0;  //!< relative to yaw_ref_rad_
    double inv_var = 0.0;
  };
  static void add(FitSum& sum, const StillFit& f) noexcept {
    sum.position_m += f.position_m;
    sum.yaw_rad += f.yaw_rad;
    sum.inv_var += f.inv_var;
    ++sum.count;
  }
  //! Moves the ring's oldest fit to the older sum.
  void retire_oldest() noexcept;
  //! Forgets the still period: the next fit starts a new one.
  void restart_still() noexcept;

  TrackerConfig config_;
  std::array<std::uint8_t, kMaxTagsPerObstacle> tag_ids_{};
  std::array<Eigen::Vector3d, kMaxTagsPerObstacle> local_m_{};
  std::size_t num_tags_ = 0;
  std::array<Fix, kMaxTagsPerObstacle> fixes_{};
  std::array<Latest, kMaxTagsPerObstacle> latest_{};
  bool yaw_observable_ = false;  //!< two tags apart in plan view

  bool have_pose_ = false;
  double yaw_rad_ = 0.0;
  Eigen::Vector3d position_m_ = Eigen::Vector3d::Zero();
  double sigma_m_ = 0.0;
  std::int64_t last_update_us_ = 0;
  TrackerCounters counters_{};

  std::array<StillFit, kStillRing> ring_{};  //!< the still period's fits within still_window_us
  std::size_t ring_head_ = 0;                //!< oldest entry
  std::size_t ring_count_ = 0;
  FitSum recent_{};                          //!< of the ring
  FitSum older_{};                           //!< of the still period's fits before the ring
  double yaw_ref_rad_ = 0.0;
  std::int64_t still_since_us_ = 0;          //!< the still period's first fit [µs]
  bool still_ = false;
  //! The newest fit, which the outlier gate predicts from (the pose may be the still average).
  double fit_yaw_rad_ = 0.0;
  Eigen::Vector3d fit_position_m_ = Eigen::Vector3d::Zero();
};

}  // namespace mgc::firmware

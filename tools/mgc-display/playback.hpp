// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <atomic>
#include <cstdint>
#include <mutex>
#include <stdexcept>
#include <string>
#include <vector>

#include "feed_state.hpp"

namespace mgc::display {

//! Thrown by Playback's constructor with a one-line message naming the file and what is wrong.
class PlaybackError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

//! A recorded LCM log (lcm-logger, lcm::LogFile) played into a FeedState in the log's own time,
//! with play, pause, speed and seek from the page.
class Playback {
 public:
  //! Reads the whole log. Throws PlaybackError for a file that cannot be read, holds no LCM event,
  //! does not start with one (not an LCM log) or ends inside one (truncated).
  explicit Playback(const std::string& path);

  //! Plays until stop: every 10 ms the position moves on by the elapsed time times the speed, and
  //! every event up to it goes into feed. A seek backwards clears feed and plays again from the start.
  void run(FeedState& feed, const std::atomic<bool>& stop);

  //! action: "play", "pause", "speed" (value 0.1..10) or "seek" (value in s from the start). False
  //! with error set on anything else.
  bool control(const std::string& action, const std::string& value, std::string& error);

  //! The position since the log's first event; FeedState's clock in playback. [µs]
  [[nodiscard]] std::int64_t position_us() const;
  //! {position_s, duration_s, playing, speed, events}
  [[nodiscard]] std::string json() const;

 private:
  struct Event {
    std::int64_t offset_us = 0;  //!< since the first event [µs]
    std::int64_t recorded_us = 0;  //!< the logger's wall-clock receive time (the log's timestamp) [µs]
    std::string channel;
    std::vector<std::uint8_t> data;
  };
  std::vector<Event> events_;
  std::int64_t duration_us_ = 0;
  mutable std::mutex mutex_;
  std::int64_t position_us_ = 0;
  bool playing_ = true;
  double speed_ = 1.0;
  bool rewind_ = false;
};

}  // namespace mgc::display

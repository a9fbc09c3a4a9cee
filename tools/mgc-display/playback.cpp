// SPDX-License-Identifier: Apache-2.0
#include "playback.hpp"

#include <lcm/lcm-cpp.hpp>
#include <sys/stat.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <thread>

#include "json.hpp"

namespace mgc::display {
namespace {

// An event's header in the file: sync word, event number, timestamp, channel and data lengths.
constexpr long kEventHeaderBytes = 4 + 8 + 8 + 4 + 4;

}  // namespace

Playback::Playback(const std::string& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) throw PlaybackError(path + ": " + std::strerror(errno));
  if (!S_ISREG(st.st_mode)) throw PlaybackError(path + ": not a regular file");
  lcm::LogFile log(path, "r");
  if (!log.good()) throw PlaybackError(path + ": cannot be opened as an LCM log");
  long end = 0;  // where the last whole event ends [bytes]
  std::int64_t first_us = 0;
  while (const lcm::LogEvent* e = log.readNextEvent()) {
    const long at = std::ftell(log.getFilePtr());
    // The reader skips bytes until it finds a sync word: an event must follow the previous one
    // directly, or the bytes between are not LCM events.
    if (at != end + kEventHeaderBytes + static_cast<long>(e->channel.size()) + e->datalen) {
      throw PlaybackError(path + ": byte " + std::to_string(end) + ": expected an LCM log event (sync word 0xEDA1DA01); not an LCM log, or damaged");
    }
    end = at;
    if (events_.empty()) first_us = e->timestamp;
    Event ev;
    ev.offset_us = std::max<std::int64_t>(e->timestamp - first_us, events_.empty() ? 0 : events_.back().offset_us);
    ev.recorded_us = e->timestamp;
    ev.channel = e->channel;
    const auto* bytes = static_cast<const std::uint8_t*>(e->data);
    ev.data.assign(bytes, bytes + e->datalen);
    events_.push_back(std::move(ev));
  }
  if (events_.empty()) throw PlaybackError(path + ": no LCM log event; expected a log written by lcm-logger");
  if (end != static_cast<long>(st.st_size)) {
    throw PlaybackError(path + ": " + std::to_string(st.st_size) + " bytes, the last whole event ends at byte " + std::to_string(end) +
                        "; expected whole events (truncated log)");
  }
  duration_us_ = events_.back().offset_us;
}

void Playback::run(FeedState& feed, const std::atomic<bool>& stop) {
  std::size_t next = 0;
  auto last = std::chrono::steady_clock::now();
  while (!stop) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
    const auto now = std::chrono::steady_clock::now();
    const double elapsed_us = static_cast<double>(std::chrono::duration_cast<std::chrono::microseconds>(now - last).count());
    last = now;
    std::int64_t position = 0;
    {
      const std::lock_guard lock(mutex_);
      if (playing_) {
        position_us_ = std::min(duration_us_, position_us_ + static_cast<std::int64_t>(elapsed_us * speed_));
        if (position_us_ >= duration_us_) playing_ = false;
      }
      if (rewind_) {
        rewind_ = false;
        next = 0;
        feed.clear();
      }
      position = position_us_;
    }
    for (; next < events_.size() && events_[next].offset_us <= position; ++next) {
      const Event& e = events_[next];
      feed.on_message(e.channel, e.data.data(), static_cast<int>(e.data.size()), e.offset_us, e.recorded_us);
    }
  }
}

bool Playback::control(const std::string& action, const std::string& value, std::string& error) {
  const std::lock_guard lock(mutex_);
  if (action == "play") {
    if (position_us_ >= duration_us_) {
      position_us_ = 0;
      rewind_ = true;
    }
    playing_ = true;
    return true;
  }
  if (action == "pause") {
    playing_ = false;
    return true;
  }
  char* end = nullptr;
  const double v = std::strtod(value.c_str(), &end);
  const bool number = !value.empty() && end == value.c_str() + value.size() && std::isfinite(v);
  if (action == "speed") {
    if (!number || v < 0.1 || v > 10.0) {
      error = "speed: expected a number from 0.1 to 10, got '" + value + "'";
      return false;
    }
    speed_ = v;
    return true;
  }
  if (action == "seek") {
    if (!number || v < 0.0 || v * 1e6 > static_cast<double>(duration_us_) + 1.0) {
      error = "seek: expected seconds from 0 to " + std::to_string(static_cast<double>(duration_us_) * 1e-6) + ", got '" + value + "'";
      return false;
    }
    const auto target = static_cast<std::int64_t>(v * 1e6);
    if (target < position_us_) rewind_ = true;
    position_us_ = target;
    return true;
  }
  error = "action: expected play, pause, speed or seek, got '" + action + "'";
  return false;
}

std::int64_t Playback::position_us() const {
  const std::lock_guard lock(mutex_);
  return position_us_;
}

std::string Playback::json() const {
  const std::lock_guard lock(mutex_);
  Json j;
  j.begin_object();
  j.key("position_s").value(static_cast<double>(position_us_) * 1e-6);
  j.key("duration_s").value(static_cast<double>(duration_us_) * 1e-6);
  j.key("playing").value(playing_);
  j.key("speed").value(speed_);
  j.key("events").value(static_cast<long long>(events_.size()));
  j.end_object();
  return j.str();
}

}  // namespace mgc::display

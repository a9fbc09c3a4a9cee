// SPDX-License-Identifier: Apache-2.0
// loop:NAME — endpoints of one process that share NAME form one bus. A send copies the frame into
// every other endpoint's fixed-capacity receive ring under the bus's mutex; a full ring counts the
// frame as lost and receive() reports RxOverflow, as a controller's overrun flag would.
#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "bus_common.hpp"

namespace mgc::hal::detail {

namespace {

class LoopEndpoint;

struct LoopHub {
  std::string name;
  std::mutex mutex;
  std::condition_variable readable;
  std::vector<LoopEndpoint*> endpoints;  // changed only on open and close
};

// Hubs live as long as an endpoint uses them; the registry only finds them by name.
std::mutex g_registry_mutex;
std::map<std::string, std::weak_ptr<LoopHub>, std::less<>> g_registry;

class LoopEndpoint final : public CanBus {
 public:
  LoopEndpoint(std::shared_ptr<LoopHub> hub, std::size_t capacity, const Clock& clock)
      : hub_(std::move(hub)), ring_(capacity), clock_(clock) {}

  ~LoopEndpoint() override {
    const std::lock_guard lock(hub_->mutex);
    auto& eps = hub_->endpoints;
    eps.erase(std::remove(eps.begin(), eps.end(), this), eps.end());
  }

  Status send(const CanFrame& frame) noexcept override {
    if (!frame.valid()) {
      const std::lock_guard lock(hub_->mutex);
      ++counters_.tx_failed;
      return Status::InvalidFrame;
    }
    {
      const std::lock_guard lock(hub_->mutex);
      if (state_ == BusState::BusOff) {
        ++counters_.tx_failed;
        return Status::BusOff;
      }
      ++counters_.tx_frames;
      for (LoopEndpoint* other : hub_->endpoints) {
        if (other != this) other->deliver_locked(frame);
      }
    }
    hub_->readable.notify_all();
    return Status::Ok;
  }

  ReceiveResult receive(std::span<TimedFrame> out) noexcept override {
    const std::lock_guard lock(hub_->mutex);
    ReceiveResult r;
    while (r.count < out.size() && size_ > 0) {
      out[r.count++] = ring_[head_];
      head_ = (head_ + 1) % ring_.size();
      --size_;
    }
    counters_.rx_frames += r.count;
    if (lost_since_receive_) {
      r.status = Status::RxOverflow;
      lost_since_receive_ = false;
    } else if (state_ == BusState::BusOff) {
      r.status = Status::BusOff;
    }
    return r;
  }

  Status wait_readable(std::int64_t timeout_us) noexcept override {
    std::unique_lock lock(hub_->mutex);
    const bool ready = hub_->readable.wait_for(lock, std::chrono::microseconds(std::max<std::int64_t>(0, timeout_us)),
                                               [this] { return size_ > 0; });
    return ready ? Status::Ok : Status::Timeout;
  }

  Status set_filters(std::span<const CanFilter> filters) noexcept override {
    const std::lock_guard lock(hub_->mutex);
    return policy_.set_filters(filters);
  }

  Status set_error_mask(std::uint32_t class_mask) noexcept override {
    const std::lock_guard lock(hub_->mutex);
    policy_.set_error_mask(class_mask);
    return Status::Ok;
  }

  BusState state() const noexcept override {
    const std::lock_guard lock(hub_->mutex);
    return state_;
  }

  BusCounters counters() const noexcept override {
    const std::lock_guard lock(hub_->mutex);
    return counters_;
  }

  std::string url() const override { return "loop:" + hub_->name + ",rx_queue=" + std::to_string(ring_.size()); }

 private:
  // Called with the hub's mutex held by the sending endpoint.
  void deliver_locked(const CanFrame& frame) noexcept {
    if (!policy_.admit(frame, state_, counters_)) return;
    if (size_ == ring_.size()) {
      ++counters_.rx_lost;
      lost_since_receive_ = true;
      return;
    }
    ring_[(head_ + size_) % ring_.size()] = {frame, monotonic_us(clock_.now_us(), last_t_us_)};
    ++size_;
  }

  std::shared_ptr<LoopHub> hub_;
  std::vector<TimedFrame> ring_;  // sized at open, never resized
  std::size_t head_ = 0;
  std::size_t size_ = 0;
  bool lost_since_receive_ = false;
  std::int64_t last_t_us_ = 0;
  const Clock& clock_;
  RxPolicy policy_;
  BusState state_ = BusState::ErrorActive;
  BusCounters counters_;
};

}  // namespace

OpenResult open_loop_bus(std::string_view name, std::size_t rx_queue_frames, const Clock& clock) {
  std::shared_ptr<LoopHub> hub;
  {
    const std::lock_guard lock(g_registry_mutex);
    auto it = g_registry.find(name);
    if (it != g_registry.end()) hub = it->second.lock();
    if (!hub) {
      hub = std::make_shared<LoopHub>();
      hub->name = std::string(name);
      g_registry[std::string(name)] = hub;
    }
    // Drop names whose buses have closed so the registry does not grow without bound.
    std::erase_if(g_registry, [](const auto& entry) { return entry.second.expired(); });
  }
  auto endpoint = std::make_unique<LoopEndpoint>(hub, rx_queue_frames, clock);
  {
    const std::lock_guard lock(hub->mutex);
    hub->endpoints.push_back(endpoint.get());
  }
  return {std::move(endpoint), Status::Ok, {}};
}

}  // namespace mgc::hal::detail

// SPDX-License-Identifier: Apache-2.0
// socketcan:IFNAME — a non-blocking CAN_RAW socket. The kernel does the filtering
// (CAN_RAW_FILTER), reports controller errors as error frames (CAN_RAW_ERR_FILTER), stamps each
// frame on arrival (SO_TIMESTAMP) and counts frames it dropped for us (SO_RXQ_OVFL).
#include <linux/can.h>
#include <linux/can/error.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <sys/uio.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstring>
#include <ctime>
#include <string>

#include "bus_common.hpp"

#ifndef SO_RXQ_OVFL
#define SO_RXQ_OVFL 40
#endif

namespace mgc::hal::detail {

namespace {

// Error classes the endpoint always asks the kernel for, to track the bus state. Bus errors and
// protocol violations are left out on purpose: on a bad bus they arrive by the ten thousand per
// second (DOMAIN-FACTS §2.3).
constexpr std::uint32_t kTrackedErrorClasses = kCanErrTxTimeout | kCanErrCrtl | kCanErrBusOff | kCanErrRestarted;

std::string errno_text(const char* what, int err) {
  return std::string(what) + " failed: " + std::strerror(err) + " (errno " + std::to_string(err) + ")";
}

std::int64_t realtime_now_us() noexcept {
  timespec ts{};
  ::clock_gettime(CLOCK_REALTIME, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000 + ts.tv_nsec / 1000;
}

class SocketCanEndpoint final : public CanBus {
 public:
  SocketCanEndpoint(int fd, std::string ifname, const Clock& clock) : fd_(fd), ifname_(std::move(ifname)), clock_(clock) {}
  ~SocketCanEndpoint() override { ::close(fd_); }

  Status send(const CanFrame& frame) noexcept override {
    if (!frame.valid()) {
      ++counters_.tx_failed;
      return Status::InvalidFrame;
    }
    if (state_ == BusState::BusOff) {
      ++counters_.tx_failed;
      return Status::BusOff;
    }
    can_frame f{};
    f.can_id = frame.can_id;
    f.len = frame.dlc;
    std::memcpy(f.data, frame.data.data(), frame.dlc);
    const ssize_t n = ::send(fd_, &f, sizeof f, MSG_DONTWAIT);
    if (n == static_cast<ssize_t>(sizeof f)) {
      ++counters_.tx_frames;
      return Status::Ok;
    }
    ++counters_.tx_failed;
    // ENOBUFS: the interface queue is full, which is also what a broken bus looks like.
    return (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK || errno == ENOBUFS)) ? Status::TxQueueFull
                                                                                    : Status::SendFailed;
  }

  ReceiveResult receive(std::span<TimedFrame> out) noexcept override {
    ReceiveResult r;
    // Kernel stamps are CLOCK_REALTIME; shift them onto the injected clock by the frame's age.
    const std::int64_t realtime_us = realtime_now_us();
    const std::int64_t now_us = clock_.now_us();
    while (r.count < out.size()) {
      can_frame f{};
      iovec iov{&f, sizeof f};
      alignas(cmsghdr) std::array<char, CMSG_SPACE(sizeof(timeval)) + CMSG_SPACE(sizeof(std::uint32_t))> control{};
      msghdr msg{};
      msg.msg_iov = &iov;
      msg.msg_iovlen = 1;
      msg.msg_control = control.data();
      msg.msg_controllen = control.size();
      const ssize_t n = ::recvmsg(fd_, &msg, MSG_DONTWAIT);
      if (n < 0) {
        if (errno == EINTR) continue;
        break;
      }
      if (n != static_cast<ssize_t>(sizeof f)) continue;
      std::int64_t t_us = now_us;
      for (cmsghdr* c = CMSG_FIRSTHDR(&msg); c != nullptr; c = CMSG_NXTHDR(&msg, c)) {
        if (c->cmsg_level != SOL_SOCKET) continue;
        if (c->cmsg_type == SO_TIMESTAMP) {
          timeval tv{};
          std::memcpy(&tv, CMSG_DATA(c), sizeof tv);
          const std::int64_t kernel_us = static_cast<std::int64_t>(tv.tv_sec) * 1'000'000 + tv.tv_usec;
          const std::int64_t age_us = realtime_us - kernel_us;
          t_us = now_us - (age_us > 0 ? age_us : 0);
        } else if (c->cmsg_type == SO_RXQ_OVFL) {
          std::uint32_t dropped = 0;
          std::memcpy(&dropped, CMSG_DATA(c), sizeof dropped);
          if (dropped != kernel_dropped_) {
            counters_.rx_lost += static_cast<std::uint32_t>(dropped - kernel_dropped_);
            kernel_dropped_ = dropped;
            lost_since_receive_ = true;
          }
        }
      }
      CanFrame frame;
      frame.can_id = f.can_id;
      frame.dlc = f.len <= kCanMaxDlc ? f.len : kCanMaxDlc;
      std::memcpy(frame.data.data(), f.data, frame.dlc);
      if (frame.is_error()) {
        apply_error_frame(frame, state_, counters_);
        if ((frame.can_id & policy_.error_mask()) == 0) continue;
      } else if (state_ == BusState::BusOff) {
        // The kernel keeps delivering what is already queued (and vcan never goes bus-off), but a
        // bus-off endpoint takes no part in bus traffic until the restart error frame.
        continue;
      }
      out[r.count++] = {frame, monotonic_us(t_us, last_t_us_)};
    }
    counters_.rx_frames += r.count;
    if (lost_since_receive_) {
      r.status = Status::RxOverflow;
    } else if (state_ == BusState::BusOff) {
      r.status = Status::BusOff;
    }
    lost_since_receive_ = false;
    return r;
  }

  Status wait_readable(std::int64_t timeout_us) noexcept override {
    if (timeout_us < 0) timeout_us = 0;
    pollfd p{fd_, POLLIN, 0};
    const timespec ts{static_cast<time_t>(timeout_us / 1'000'000), static_cast<long>((timeout_us % 1'000'000) * 1000)};
    return ::ppoll(&p, 1, &ts, nullptr) > 0 ? Status::Ok : Status::Timeout;
  }

  Status set_filters(std::span<const CanFilter> filters) noexcept override {
    if (filters.size() > kMaxFilters) return Status::TooManyFilters;
    std::array<can_filter, kMaxFilters> kernel{};
    for (std::size_t i = 0; i < filters.size(); ++i) kernel[i] = {filters[i].can_id, filters[i].can_mask};
    const auto bytes = static_cast<socklen_t>(filters.size() * sizeof(can_filter));
    if (::setsockopt(fd_, SOL_CAN_RAW, CAN_RAW_FILTER, filters.empty() ? nullptr : kernel.data(), bytes) != 0) {
      return Status::Error;
    }
    return policy_.set_filters(filters);
  }

  Status set_error_mask(std::uint32_t class_mask) noexcept override {
    const can_err_mask_t mask = (class_mask | kTrackedErrorClasses) & CAN_ERR_MASK;
    if (::setsockopt(fd_, SOL_CAN_RAW, CAN_RAW_ERR_FILTER, &mask, sizeof mask) != 0) return Status::Error;
    policy_.set_error_mask(class_mask);
    return Status::Ok;
  }

  BusState state() const noexcept override { return state_; }
  BusCounters counters() const noexcept override { return counters_; }
  std::string url() const override { return "socketcan:" + ifname_; }

 private:
  int fd_;
  std::string ifname_;
  const Clock& clock_;
  RxPolicy policy_;
  BusState state_ = BusState::ErrorActive;
  BusCounters counters_;
  std::uint32_t kernel_dropped_ = 0;
  bool lost_since_receive_ = false;
  std::int64_t last_t_us_ = 0;
};

}  // namespace

OpenResult open_socketcan_bus(std::string_view ifname, const Clock& clock) {
  const std::string name(ifname);
  const std::string where = "CAN bus URL 'socketcan:" + name + "': ";
  const int fd = ::socket(PF_CAN, SOCK_RAW | SOCK_NONBLOCK | SOCK_CLOEXEC, CAN_RAW);
  if (fd < 0) {
    const int err = errno;
    const bool no_can = err == EAFNOSUPPORT || err == EPROTONOSUPPORT;
    return {nullptr, no_can ? Status::Unsupported : Status::OsError,
            where + errno_text("socket(PF_CAN, SOCK_RAW, CAN_RAW)", err) +
                (no_can ? "; this kernel has no SocketCAN, use udp: or run in the vcan VM" : "")};
  }
  const auto fail = [&](const char* what) {
    const int err = errno;
    ::close(fd);
    return OpenResult{nullptr, Status::OsError, where + errno_text(what, err)};
  };
  const unsigned index = ::if_nametoindex(name.c_str());
  if (index == 0) return fail("if_nametoindex");
  sockaddr_can addr{};
  addr.can_family = AF_CAN;
  addr.can_ifindex = static_cast<int>(index);
  if (::bind(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) != 0) return fail("bind");
  const int on = 1;
  if (::setsockopt(fd, SOL_SOCKET, SO_TIMESTAMP, &on, sizeof on) != 0) return fail("setsockopt(SO_TIMESTAMP)");
  if (::setsockopt(fd, SOL_SOCKET, SO_RXQ_OVFL, &on, sizeof on) != 0) return fail("setsockopt(SO_RXQ_OVFL)");
  const can_err_mask_t mask = kTrackedErrorClasses;
  if (::setsockopt(fd, SOL_CAN_RAW, CAN_RAW_ERR_FILTER, &mask, sizeof mask) != 0) {
    return fail("setsockopt(CAN_RAW_ERR_FILTER)");
  }
  return {std::make_unique<SocketCanEndpoint>(fd, name, clock), Status::Ok, {}};
}

}  // namespace mgc::hal::detail

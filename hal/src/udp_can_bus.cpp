// SPDX-License-Identifier: Apache-2.0
// udp:HOST:PORT — classic CAN frames in cannelloni format 2 datagrams, one frame per datagram,
// sent to every configured peer. Receiving takes any cannelloni DATA datagram (batched ones too),
// stamps it with the injected clock when drained, and counts gaps in each sender's sequence
// number as lost datagrams.
#include <arpa/inet.h>
#include <cerrno>
#include <cstring>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <ctime>
#include <string>

#include "bus_common.hpp"
#include "mgc/hal/cannelloni.hpp"
#include "mgc/hal/udp_can_bus.hpp"

namespace mgc::hal::detail {

namespace {

constexpr std::size_t kMaxTrackedSenders = 16;
// Bounds the work of one receive() call when datagrams carry nothing that passes the filters.
constexpr std::size_t kMaxDatagramsPerReceive = 1024;

sockaddr_in to_sockaddr(const Ipv4Endpoint& e) noexcept {
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(e.address);
  a.sin_port = htons(e.port);
  return a;
}

std::string errno_text(const char* what, int err) {
  return std::string(what) + " failed: " + std::strerror(err) + " (errno " + std::to_string(err) + ")";
}

class UdpEndpoint final : public UdpCanBus {
 public:
  UdpEndpoint(int fd, const Ipv4Endpoint& local, const Clock& clock) : fd_(fd), local_(local), clock_(clock) {}
  ~UdpEndpoint() override { ::close(fd_); }

  std::uint16_t local_port() const noexcept override { return local_.port; }

  Status add_peer(std::string_view host_port) override {
    Ipv4Endpoint peer;
    std::string why;
    if (!parse_ipv4_endpoint(host_port, false, peer, why)) return Status::BadUrl;
    return add_peer(peer);
  }

  Status add_peer(const Ipv4Endpoint& peer) noexcept {
    if (num_peers_ == kMaxUdpPeers) return Status::Error;
    peers_[num_peers_++] = peer;
    return Status::Ok;
  }

  Status send(const CanFrame& frame) noexcept override {
    if (!frame.valid()) {
      ++counters_.tx_failed;
      return Status::InvalidFrame;
    }
    if (state_ == BusState::BusOff) {
      ++counters_.tx_failed;
      return Status::BusOff;
    }
    std::array<std::uint8_t, cannelloni::kHeaderBytes + cannelloni::kFrameHeaderBytes + kCanMaxDlc> buf{};
    const std::size_t n = cannelloni::encode(std::span<const CanFrame>(&frame, 1), tx_seq_, buf);
    ++tx_seq_;
    Status result = Status::Ok;
    for (std::size_t i = 0; i < num_peers_; ++i) {
      const sockaddr_in to = to_sockaddr(peers_[i]);
      const ssize_t sent = ::sendto(fd_, buf.data(), n, MSG_DONTWAIT | MSG_NOSIGNAL, reinterpret_cast<const sockaddr*>(&to),
                                    sizeof to);
      if (sent < 0) {
        result = (errno == EAGAIN || errno == EWOULDBLOCK || errno == ENOBUFS) ? Status::TxQueueFull : Status::SendFailed;
      }
    }
    if (result == Status::Ok) {
      ++counters_.tx_frames;
    } else {
      ++counters_.tx_failed;
    }
    return result;
  }

  ReceiveResult receive(std::span<TimedFrame> out) noexcept override {
    ReceiveResult r;
    for (std::size_t datagrams = 0;; ++datagrams) {
      while (r.count < out.size() && pending_size_ > 0) {
        out[r.count++] = pending_[pending_head_++];
        --pending_size_;
      }
      if (r.count == out.size() || datagrams == kMaxDatagramsPerReceive) break;
      if (!read_datagram()) break;
    }
    counters_.rx_frames += r.count;
    if (lost_since_receive_) {
      r.status = Status::RxOverflow;
    } else if (malformed_since_receive_) {
      r.status = Status::MalformedDatagram;
    } else if (state_ == BusState::BusOff) {
      r.status = Status::BusOff;
    }
    lost_since_receive_ = false;
    malformed_since_receive_ = false;
    return r;
  }

  Status wait_readable(std::int64_t timeout_us) noexcept override {
    if (pending_size_ > 0) return Status::Ok;
    if (timeout_us < 0) timeout_us = 0;
    pollfd p{fd_, POLLIN, 0};
    const timespec ts{static_cast<time_t>(timeout_us / 1'000'000), static_cast<long>((timeout_us % 1'000'000) * 1000)};
    const int n = ::ppoll(&p, 1, &ts, nullptr);
    return n > 0 ? Status::Ok : Status::Timeout;
  }

  Status set_filters(std::span<const CanFilter> filters) noexcept override { return policy_.set_filters(filters); }
  Status set_error_mask(std::uint32_t class_mask) noexcept override {
    policy_.set_error_mask(class_mask);
    return Status::Ok;
  }
  BusState state() const noexcept override { return state_; }
  BusCounters counters() const noexcept override { return counters_; }

  std::string url() const override {
    std::string u = "udp:" + format_ipv4_endpoint(local_);
    for (std::size_t i = 0; i < num_peers_; ++i) u += ",peer=" + format_ipv4_endpoint(peers_[i]);
    return u;
  }

 private:
  struct Sender {
    std::uint32_t address = 0;
    std::uint16_t port = 0;
    std::uint8_t last_seq = 0;
    bool used = false;
  };

  // Reads one datagram into pending_ (which is empty). False when nothing is waiting.
  bool read_datagram() noexcept {
    sockaddr_in from{};
    socklen_t from_len = sizeof from;
    const ssize_t n = ::recvfrom(fd_, rx_buf_.data(), rx_buf_.size(), MSG_DONTWAIT, reinterpret_cast<sockaddr*>(&from),
                                 &from_len);
    if (n < 0) return errno == EINTR;
    const Ipv4Endpoint source{ntohl(from.sin_addr.s_addr), ntohs(from.sin_port)};
    // A peer list that names ourselves must not make us hear our own frames.
    if (source.port == local_.port && (source.address == local_.address || local_.address == INADDR_ANY)) return true;
    cannelloni::Header header;
    std::size_t count = 0;
    const Status s = cannelloni::decode(std::span<const std::uint8_t>(rx_buf_.data(), static_cast<std::size_t>(n)),
                                        header, scratch_, count);
    if (s != Status::Ok) {
      ++counters_.rx_malformed;
      malformed_since_receive_ = true;
      return true;
    }
    if (header.op_code != cannelloni::kOpData) return true;
    track_sequence(source, header.seq_no);
    const std::int64_t t_us = monotonic_us(clock_.now_us(), last_t_us_);
    pending_head_ = 0;
    for (std::size_t i = 0; i < count; ++i) {
      if (policy_.admit(scratch_[i], state_, counters_)) pending_[pending_size_++] = {scratch_[i], t_us};
    }
    return true;
  }

  void track_sequence(const Ipv4Endpoint& source, std::uint8_t seq) noexcept {
    Sender* free_slot = nullptr;
    for (Sender& s : senders_) {
      if (s.used && s.address == source.address && s.port == source.port) {
        const auto gap = static_cast<std::uint8_t>(seq - static_cast<std::uint8_t>(s.last_seq + 1));
        if (gap != 0) {
          counters_.rx_lost += gap;
          lost_since_receive_ = true;
        }
        s.last_seq = seq;
        return;
      }
      if (!s.used && free_slot == nullptr) free_slot = &s;
    }
    if (free_slot != nullptr) *free_slot = {source.address, source.port, seq, true};
  }

  int fd_;
  Ipv4Endpoint local_;
  const Clock& clock_;
  std::array<Ipv4Endpoint, kMaxUdpPeers> peers_{};
  std::size_t num_peers_ = 0;
  std::uint8_t tx_seq_ = 0;
  std::array<std::uint8_t, 2048> rx_buf_{};
  std::array<CanFrame, cannelloni::kMaxFramesPerDatagram> scratch_{};
  std::array<TimedFrame, cannelloni::kMaxFramesPerDatagram> pending_{};
  std::size_t pending_head_ = 0;
  // Atomic: wait_readable() may run on another thread than receive() (mgc-sim's loop threads).
  std::atomic<std::size_t> pending_size_{0};
  std::array<Sender, kMaxTrackedSenders> senders_{};
  bool lost_since_receive_ = false;
  bool malformed_since_receive_ = false;
  std::int64_t last_t_us_ = 0;
  RxPolicy policy_;
  BusState state_ = BusState::ErrorActive;
  BusCounters counters_;
};

}  // namespace

OpenResult open_udp_bus(const Ipv4Endpoint& local, std::span<const Ipv4Endpoint> peers, const Clock& clock) {
  const std::string where = "CAN bus URL 'udp:" + format_ipv4_endpoint(local) + "': ";
  const int fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (fd < 0) return {nullptr, Status::OsError, where + errno_text("socket(AF_INET, SOCK_DGRAM)", errno)};
  const sockaddr_in addr = to_sockaddr(local);
  if (::bind(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) != 0) {
    const int err = errno;
    ::close(fd);
    return {nullptr, Status::OsError, where + errno_text("bind", err)};
  }
  sockaddr_in bound{};
  socklen_t len = sizeof bound;
  if (::getsockname(fd, reinterpret_cast<sockaddr*>(&bound), &len) != 0) {
    const int err = errno;
    ::close(fd);
    return {nullptr, Status::OsError, where + errno_text("getsockname", err)};
  }
  auto bus = std::make_unique<UdpEndpoint>(fd, Ipv4Endpoint{ntohl(bound.sin_addr.s_addr), ntohs(bound.sin_port)}, clock);
  for (const Ipv4Endpoint& peer : peers) {
    if (bus->add_peer(peer) != Status::Ok) return {nullptr, Status::BadUrl, where + "too many peers"};
  }
  return {std::move(bus), Status::Ok, {}};
}

}  // namespace mgc::hal::detail

// SPDX-License-Identifier: Apache-2.0
#include "mgc/hal/cannelloni.hpp"

namespace mgc::hal::cannelloni {

namespace {

std::uint32_t get_u32_be(const std::uint8_t* p) noexcept {
  return (static_cast<std::uint32_t>(p[0]) << 24) | (static_cast<std::uint32_t>(p[1]) << 16) |
         (static_cast<std::uint32_t>(p[2]) << 8) | static_cast<std::uint32_t>(p[3]);
}

void put_u32_be(std::uint8_t* p, std::uint32_t v) noexcept {
  p[0] = static_cast<std::uint8_t>(v >> 24);
  p[1] = static_cast<std::uint8_t>((v >> 16) & 0xFFU);
  p[2] = static_cast<std::uint8_t>((v >> 8) & 0xFFU);
  p[3] = static_cast<std::uint8_t>(v & 0xFFU);
}

}  // namespace

std::size_t encode(std::span<const CanFrame> frames, std::uint8_t seq_no, std::span<std::uint8_t> out) noexcept {
  if (frames.size() > 0xFFFFU) return 0;
  std::size_t need = kHeaderBytes;
  for (const CanFrame& f : frames) {
    if (!f.valid()) return 0;
    need += kFrameHeaderBytes + f.dlc;
  }
  if (need > out.size()) return 0;
  std::uint8_t* p = out.data();
  p[0] = kVersion;
  p[1] = kOpData;
  p[2] = seq_no;
  p[3] = static_cast<std::uint8_t>(frames.size() >> 8);
  p[4] = static_cast<std::uint8_t>(frames.size() & 0xFFU);
  p += kHeaderBytes;
  for (const CanFrame& f : frames) {
    put_u32_be(p, f.can_id);
    p[4] = f.dlc;
    p += kFrameHeaderBytes;
    for (std::size_t i = 0; i < f.dlc; ++i) *p++ = f.data[i];
  }
  return need;
}

Status decode(std::span<const std::uint8_t> datagram, Header& header, std::span<CanFrame> frames,
              std::size_t& count) noexcept {
  count = 0;
  if (datagram.size() < kHeaderBytes) return Status::WrongLength;
  const std::uint8_t* p = datagram.data();
  Header h;
  h.version = p[0];
  h.op_code = p[1];
  h.seq_no = p[2];
  h.count = static_cast<std::uint16_t>((p[3] << 8) | p[4]);
  if (h.version != kVersion) return Status::OutOfRange;
  if (h.op_code != kOpData) {
    header = h;
    return Status::Ok;
  }
  if (h.count > frames.size()) return Status::OutOfRange;
  // First pass: validate the whole datagram so that a bad one leaves frames untouched.
  std::size_t at = kHeaderBytes;
  for (std::size_t i = 0; i < h.count; ++i) {
    if (datagram.size() - at < kFrameHeaderBytes) return Status::WrongLength;
    const std::uint8_t len = p[at + 4];
    if ((len & kCanFdFlag) != 0) return Status::Unsupported;
    if (len > kCanMaxDlc) return Status::OutOfRange;
    CanFrame probe;
    probe.can_id = get_u32_be(p + at);
    if (!probe.valid()) return Status::OutOfRange;
    at += kFrameHeaderBytes;
    if (datagram.size() - at < len) return Status::WrongLength;
    at += len;
  }
  if (at != datagram.size()) return Status::WrongLength;
  at = kHeaderBytes;
  for (std::size_t i = 0; i < h.count; ++i) {
    CanFrame f;
    f.can_id = get_u32_be(p + at);
    f.dlc = p[at + 4];
    at += kFrameHeaderBytes;
    for (std::size_t b = 0; b < f.dlc; ++b) f.data[b] = p[at + b];
    at += f.dlc;
    frames[i] = f;
  }
  header = h;
  count = h.count;
  return Status::Ok;
}

}  // namespace mgc::hal::cannelloni

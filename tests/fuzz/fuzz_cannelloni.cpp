// SPDX-License-Identifier: Apache-2.0
// The cannelloni UDP datagram decoder (hal/src/cannelloni.cpp): the input is one datagram as the
// UDP transport receives it. A datagram the decoder accepts must encode back to the same bytes;
// one it refuses must leave the frames untouched.
#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "fuzz_support.hpp"
#include "mgc/hal/cannelloni.hpp"

using namespace mgc::hal;
using mgc::fuzz::require;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size > cannelloni::kMaxDatagramBytes) return -1;  // the transport never reads more
  const std::span<const std::uint8_t> datagram(data, size);

  static std::array<CanFrame, cannelloni::kMaxFramesPerDatagram> frames;
  // A marker frame in every slot: a refused datagram must leave it in place.
  CanFrame marker = CanFrame::standard(0x7FF, 8);
  marker.data.fill(0xA5);
  frames.fill(marker);

  cannelloni::Header header;
  std::size_t count = 12345;
  const Status status = cannelloni::decode(datagram, header, frames, count);
  if (status != Status::Ok) {
    require(status == Status::WrongLength || status == Status::OutOfRange || status == Status::Unsupported,
            "cannelloni::decode returned a status it does not document");
    require(count == 0, "a refused datagram gave frames");
    require(std::all_of(frames.begin(), frames.end(), [&](const CanFrame& f) { return f == marker; }),
            "a refused datagram wrote frames");
    return 0;
  }
  require(size >= cannelloni::kHeaderBytes && header.version == cannelloni::kVersion, "accepted a bad header");
  if (header.op_code != cannelloni::kOpData) {
    require(count == 0, "an ACK/NACK datagram gave frames");
    return 0;
  }
  require(count == header.count && count <= frames.size(), "frame count differs from the header");
  for (std::size_t i = 0; i < count; ++i) {
    require(frames[i].valid(), "the decoder gave an invalid frame");
    for (std::size_t b = frames[i].dlc; b < frames[i].data.size(); ++b) {
      require(frames[i].data[b] == 0, "payload bytes beyond dlc are not zero");
    }
  }
  std::array<std::uint8_t, cannelloni::kMaxDatagramBytes> again{};
  const std::size_t n = cannelloni::encode(std::span(frames.data(), count), header.seq_no, again);
  require(n == size, "an accepted datagram encodes back to another length");
  require(std::equal(again.begin(), again.begin() + static_cast<std::ptrdiff_t>(n), datagram.begin()),
          "an accepted datagram encodes back to other bytes");
  return 0;
}

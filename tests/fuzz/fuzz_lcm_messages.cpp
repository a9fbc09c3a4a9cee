// SPDX-License-Identifier: Apache-2.0
// LCM's generated decode() of the messages our programs take from the network besides operator
// commands (fuzz_operator_command): mgc-operator receives machine_state_t, operator_instruction_t,
// alert_t and command_status_t. The first byte picks the type, the rest is the message as it
// arrives. A message either fails to decode (a negative length) or decodes into one that encodes
// and decodes again to itself; nothing may throw, allocate without bound or read past the buffer.
#include <mgc/alert_t.hpp>
#include <mgc/command_status_t.hpp>
#include <mgc/machine_state_t.hpp>
#include <mgc/operator_instruction_t.hpp>

#include <cstddef>
#include <cstdint>
#include <vector>

#include "fuzz_support.hpp"

using mgc::fuzz::require;

namespace {

template <class Msg>
std::vector<std::uint8_t> encoded(const Msg& msg) {
  std::vector<std::uint8_t> out(static_cast<std::size_t>(msg.getEncodedSize()));
  const int n = msg.encode(out.data(), 0, static_cast<int>(out.size()));
  require(n > 0, "a decoded message does not encode");
  out.resize(static_cast<std::size_t>(n));
  return out;
}

// Decoding is not a bijection (a string's bytes after an embedded NUL are dropped when it is
// encoded again), so the property is that one decode-encode pass reaches a fixed point.
template <class Msg>
void decode_one(const std::uint8_t* data, int size) {
  Msg msg{};
  const int used = msg.decode(data, 0, size);
  if (used < 0) return;
  require(used <= size, "decode() used more bytes than it was given");
  const std::vector<std::uint8_t> first = encoded(msg);
  Msg again{};
  require(again.decode(first.data(), 0, static_cast<int>(first.size())) == static_cast<int>(first.size()),
          "an encoded message does not decode");
  require(encoded(again) == first, "decode and encode do not reach a fixed point");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1 || size > 65536) return -1;
  const int n = static_cast<int>(size - 1);
  switch (data[0] % 4) {
    case 0: decode_one<mgc::machine_state_t>(data + 1, n); break;
    case 1: decode_one<mgc::operator_instruction_t>(data + 1, n); break;
    case 2: decode_one<mgc::alert_t>(data + 1, n); break;
    default: decode_one<mgc::command_status_t>(data + 1, n); break;
  }
  return 0;
}

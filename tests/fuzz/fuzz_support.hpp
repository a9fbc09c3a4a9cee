// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <span>

// Shared by the fuzz targets: reading fields off the input, and failing loudly.
namespace mgc::fuzz {

//! Takes bytes off the front of the fuzzer's input; past its end every read gives zeros, so that a
//! target never has to check the length first.
class Input {
 public:
  Input(const std::uint8_t* data, std::size_t size) noexcept : data_(data), size_(size) {}

  [[nodiscard]] bool empty() const noexcept { return at_ >= size_; }
  [[nodiscard]] std::size_t remaining() const noexcept { return empty() ? 0 : size_ - at_; }

  [[nodiscard]] std::uint8_t u8() noexcept { return at_ < size_ ? data_[at_++] : std::uint8_t{0}; }
  [[nodiscard]] std::uint16_t u16() noexcept {
    const auto hi = static_cast<std::uint16_t>(u8() << 8);
    return static_cast<std::uint16_t>(hi | u8());
  }
  [[nodiscard]] std::uint32_t u32() noexcept {
    const std::uint32_t hi = u16();
    return (hi << 16) | u16();
  }
  //! The next n bytes (fewer at the end of the input).
  [[nodiscard]] std::span<const std::uint8_t> bytes(std::size_t n) noexcept {
    const std::size_t take = n < remaining() ? n : remaining();
    const std::span<const std::uint8_t> out(data_ + at_, take);
    at_ += take;
    return out;
  }

 private:
  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t at_ = 0;
};

//! A property the target checks does not hold: print it and abort, which libFuzzer reports as a
//! crash with the input that caused it.
[[noreturn]] inline void fail(const char* what) noexcept {
  std::fprintf(stderr, "fuzz property violated: %s\n", what);
  std::abort();
}

inline void require(bool ok, const char* what) noexcept {
  if (!ok) fail(what);
}

}  // namespace mgc::fuzz

namespace mgc::fuzz {

//! The controller's CLOCK_REALTIME in the operator command target, and the key its commands are
//! signed with; mgc_fuzz_seeds signs the seed commands with the same. [µs]
inline constexpr std::int64_t kCommandNowUs = 1'800'000'000'000'000;
[[nodiscard]] inline constexpr std::array<std::uint8_t, 32> command_key_bytes() noexcept {
  std::array<std::uint8_t, 32> k{};
  for (std::size_t i = 0; i < k.size(); ++i) k[i] = static_cast<std::uint8_t>(0x5A + 11 * i);
  return k;
}

}  // namespace mgc::fuzz

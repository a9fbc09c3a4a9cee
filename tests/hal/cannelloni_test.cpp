// SPDX-License-Identifier: Apache-2.0
#include <catch2/catch.hpp>

#include <array>
#include <vector>

#include "mgc/hal/cannelloni.hpp"

using namespace mgc::hal;

TEST_CASE("cannelloni datagrams round trip and match the documented bytes", "[unit][codec]") {
  CanFrame a = CanFrame::standard(0x123, 2);
  a.data[0] = 0xAA;
  a.data[1] = 0xBB;
  CanFrame b;
  b.can_id = kCanEffFlag | 0x1234567U;
  b.dlc = 0;
  const std::array<CanFrame, 2> frames{a, b};
  std::array<std::uint8_t, 64> buf{};
  const std::size_t n = cannelloni::encode(frames, 0x42, buf);
  const std::vector<std::uint8_t> expected{2,    0,    0x42, 0x00, 0x02,                    // header
                                           0x00, 0x00, 0x01, 0x23, 0x02, 0xAA, 0xBB,        // frame a
                                           0x81, 0x23, 0x45, 0x67, 0x00};                   // frame b
  REQUIRE(n == expected.size());
  CHECK(std::vector<std::uint8_t>(buf.begin(), buf.begin() + static_cast<std::ptrdiff_t>(n)) == expected);

  cannelloni::Header h;
  std::array<CanFrame, 4> out{};
  std::size_t count = 0;
  REQUIRE(cannelloni::decode(std::span(buf.data(), n), h, out, count) == Status::Ok);
  CHECK(h.seq_no == 0x42);
  REQUIRE(count == 2);
  CHECK(out[0] == a);
  CHECK(out[1] == b);

  std::array<std::uint8_t, 8> tiny{};
  CHECK(cannelloni::encode(frames, 0, tiny) == 0);
}

TEST_CASE("cannelloni decoder refuses malformed datagrams and writes nothing", "[unit][codec]") {
  const CanFrame a = CanFrame::standard(0x181, 5);
  std::array<std::uint8_t, 32> buf{};
  const std::size_t n = cannelloni::encode(std::span(&a, 1), 1, buf);
  std::vector<std::uint8_t> good(buf.begin(), buf.begin() + static_cast<std::ptrdiff_t>(n));
  const auto decode = [](const std::vector<std::uint8_t>& d, std::size_t& count) {
    cannelloni::Header h;
    std::array<CanFrame, 2> out{};
    return cannelloni::decode(d, h, out, count);
  };
  std::size_t count = 99;
  REQUIRE(decode(good, count) == Status::Ok);
  CHECK(count == 1);

  auto short_header = std::vector<std::uint8_t>(good.begin(), good.begin() + 4);
  CHECK(decode(short_header, count) == Status::WrongLength);
  CHECK(count == 0);
  auto truncated = std::vector<std::uint8_t>(good.begin(), good.end() - 1);
  CHECK(decode(truncated, count) == Status::WrongLength);
  auto trailing = good;
  trailing.push_back(0);
  CHECK(decode(trailing, count) == Status::WrongLength);
  auto version = good;
  version[0] = 1;
  CHECK(decode(version, count) == Status::OutOfRange);
  auto len9 = good;
  len9[9] = 9;
  CHECK(decode(len9, count) == Status::OutOfRange);
  auto fd = good;
  fd[9] = cannelloni::kCanFdFlag | 5;
  CHECK(decode(fd, count) == Status::Unsupported);
  auto too_many = good;
  too_many[4] = 3;  // count 3 > the two-frame output
  CHECK(decode(too_many, count) == Status::OutOfRange);
  auto wide_standard_id = good;
  wide_standard_id[7] = 0x08;  // id 0x881 without the EFF flag
  CHECK(decode(wide_standard_id, count) == Status::OutOfRange);
  auto ack = good;
  ack[1] = 1;
  CHECK(decode(ack, count) == Status::Ok);
  CHECK(count == 0);
}

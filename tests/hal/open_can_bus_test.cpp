// SPDX-License-Identifier: Apache-2.0
#include <catch2/catch.hpp>

#include <cerrno>
#include <string>
#include <sys/socket.h>
#include <unistd.h>

#include "mgc/hal/can_bus.hpp"
#include "mgc/hal/udp_can_bus.hpp"

using namespace mgc::hal;

namespace {

void check_bad(const std::string& url, const std::string& reason_part) {
  CAPTURE(url);
  const OpenResult r = open_can_bus(url);
  CHECK_FALSE(r);
  CHECK(r.status == Status::BadUrl);
  CHECK(r.error.find(url) != std::string::npos);
  CHECK(r.error.find(reason_part) != std::string::npos);
}

}  // namespace

TEST_CASE("open_can_bus names the URL and the reason for a bad URL", "[unit]") {
  check_bad("", "SCHEME");
  check_bad("vcan0", "SCHEME");
  check_bad("can:vcan0", "unknown scheme 'can'");
  check_bad("loop:", "bus name");
  check_bad("loop:x,rx_queue=0", "rx_queue");
  check_bad("loop:x,rx_queue=abc", "rx_queue");
  check_bad("loop:x,depth=3", "unknown loop option");
  check_bad("udp:", "HOST:PORT");
  check_bad("udp:127.0.0.1", "HOST:PORT");
  check_bad("udp:127.0.0.1:70000", "port '70000'");
  check_bad("udp:127.0.0.1:-1", "port '-1'");
  check_bad("udp:127.0.0.1:port", "port 'port'");
  check_bad("udp:127.0.0.1:", "port ''");
  check_bad("udp:127.0.0:20000", "not an IPv4 address");
  check_bad("udp:127.0.0.256:20000", "not an IPv4 address");
  check_bad("udp:example.com:20000", "not an IPv4 address");
  check_bad("udp:127.0.0.1:0,peer=127.0.0.1:0", "peer port '0'");
  check_bad("udp:127.0.0.1:0,pier=127.0.0.1:1", "unknown udp option");
  check_bad("udp:127.0.0.1:0,peer=1.1.1.1:1,peer=1.1.1.1:2,peer=1.1.1.1:3,peer=1.1.1.1:4,peer=1.1.1.1:5,"
            "peer=1.1.1.1:6,peer=1.1.1.1:7,peer=1.1.1.1:8,peer=1.1.1.1:9",
            "at most 8 peers");
  check_bad("socketcan:", "interface name");
  check_bad("socketcan:a_very_long_ifname", "interface name");
  check_bad("socketcan:vcan0,x=1", "no options");
}

TEST_CASE("open_can_bus opens udp endpoints and reports the port the OS chose", "[unit]") {
  auto a = open_can_bus("udp:127.0.0.1:0");
  REQUIRE(a);
  const auto port = dynamic_cast<UdpCanBus&>(*a.bus).local_port();
  CHECK(port != 0);
  CHECK(a.bus->url() == "udp:127.0.0.1:" + std::to_string(port));
  auto b = open_can_bus("udp:localhost:0,peer=127.0.0.1:" + std::to_string(port));
  REQUIRE(b);
  CHECK(b.bus->url().find(",peer=127.0.0.1:" + std::to_string(port)) != std::string::npos);
  CHECK(dynamic_cast<UdpCanBus&>(*b.bus).add_peer("nonsense") == Status::BadUrl);

  // The port is taken now: a second bind fails with the OS's reason.
  const OpenResult clash = open_can_bus("udp:127.0.0.1:" + std::to_string(port));
  CHECK_FALSE(clash);
  CHECK(clash.status == Status::OsError);
  CHECK(clash.error.find("bind failed") != std::string::npos);
}

TEST_CASE("socketcan without kernel CAN support fails cleanly with the errno text", "[unit]") {
  const int probe = ::socket(PF_CAN, SOCK_RAW, 1);
  const int probe_errno = errno;
  if (probe >= 0) ::close(probe);
  const OpenResult r = open_can_bus("socketcan:vcan0");
  if (probe < 0 && probe_errno == EAFNOSUPPORT) {
    CHECK_FALSE(r);
    CHECK(r.status == Status::Unsupported);
    CHECK(r.error.find("socketcan:vcan0") != std::string::npos);
    CHECK(r.error.find("errno " + std::to_string(EAFNOSUPPORT)) != std::string::npos);
  } else if (!r) {
    // A kernel with CAN but no vcan0: the reason still comes with the errno.
    CHECK(r.status == Status::OsError);
    CHECK(r.error.find("errno") != std::string::npos);
  }
}

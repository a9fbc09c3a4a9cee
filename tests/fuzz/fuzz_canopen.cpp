// SPDX-License-Identifier: Apache-2.0
// The CANopen codec and the device PDO decoders (hal/src/canopen.cpp, device_pdos.cpp), and
// classify() against every machine's bus plan. The input is a sequence of frames: id (u32, flags
// included), dlc (u8, may exceed 8 as a raw SocketCAN frame's can_dlc could), then the payload.
// Every decoder must refuse with a documented status or accept a frame that its encoder gives
// back bit for bit: the two ends of the bus then speak one protocol.
#include <array>
#include <cstddef>
#include <cstdint>

#include "fuzz_support.hpp"
#include "mgc/hal/bus_plan.hpp"
#include "mgc/hal/canopen.hpp"
#include "mgc/hal/device_pdos.hpp"

using namespace mgc::hal;
using mgc::fuzz::require;

namespace {

bool documented(Status s) {
  return s == Status::WrongLength || s == Status::WrongId || s == Status::OutOfRange || s == Status::ReservedBits;
}

// Decode, and when that succeeds encode again and compare.
template <class Decode, class Encode>
void round_trip(const CanFrame& frame, Decode decode, Encode encode, const char* what) {
  const auto decoded = decode(frame);
  if (!decoded.ok()) {
    if (!documented(decoded.status)) mgc::fuzz::fail(what);
    return;
  }
  const Result<CanFrame> encoded = encode(decoded.value);
  require(encoded.ok(), "a decoded message does not encode");
  require(encoded.value == frame, what);
}

const std::array<BusPlan, 3>& plans() {
  static const std::array<BusPlan, 3> p{mobile_crane_bus_plan(), tower_crane_bus_plan(), excavator_bus_plan()};
  return p;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  mgc::fuzz::Input in(data, size);
  while (!in.empty()) {
    CanFrame f;
    f.can_id = in.u32();
    f.dlc = in.u8();
    // The transports zero the bytes beyond the payload; a raw dlc above 8 still carries 8.
    const auto payload = in.bytes(f.dlc < kCanMaxDlc ? f.dlc : kCanMaxDlc);
    for (std::size_t i = 0; i < payload.size(); ++i) f.data[i] = payload[i];

    round_trip(f, canopen::decode_nmt, canopen::encode_nmt, "NMT");
    round_trip(f, canopen::decode_sync, canopen::encode_sync, "SYNC");
    round_trip(f, canopen::decode_heartbeat, canopen::encode_heartbeat, "heartbeat");
    round_trip(f, canopen::decode_emcy, canopen::encode_emcy, "EMCY");
    round_trip(f, pdo::decode_encoder_position, pdo::encode_encoder_position, "encoder position");
    round_trip(f, pdo::decode_uwb_tag_position, pdo::encode_uwb_tag_position, "UWB tag position");
    round_trip(f, pdo::decode_valve_command, pdo::encode_valve_command, "valve command");
    round_trip(f, pdo::decode_valve_status, pdo::encode_valve_status, "valve status");
    round_trip(f, pdo::decode_valve_applied, pdo::encode_valve_applied, "valve applied");
    round_trip(f, pdo::decode_cutoff_command, pdo::encode_cutoff_command, "cut-off command");
    round_trip(f, pdo::decode_cutoff_status, pdo::encode_cutoff_status, "cut-off status");

    for (const BusPlan& plan : plans()) {
      const Classified c = classify(f, plan);
      if (c.kind == MessageKind::Unknown) continue;
      require((f.can_id & ~kCanSffMask) == 0, "classify() placed a frame that is not an 11-bit data frame");
      require(c.node_id <= canopen::kMaxNodeId, "classify() gave a node id beyond 127");
      if (c.kind == MessageKind::EncoderPosition) {
        require(c.index >= 0 && c.index < plan.num_joints, "classify() gave an encoder beyond the plan's joints");
      }
      if (c.kind == MessageKind::ValveCommand || c.kind == MessageKind::ValveApplied) {
        require(c.index >= 0 && static_cast<std::size_t>(c.index) < pdo::kValveBanks, "classify() gave a bank beyond 2");
      }
    }
  }
  return 0;
}

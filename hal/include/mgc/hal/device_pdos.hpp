// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <array>
#include <climits>
#include <cstddef>
#include <cstdint>

#include "mgc/hal/can_frame.hpp"
#include "mgc/hal/status.hpp"

//! Our devices' PDO payloads (docs/protocol.md §PDOs): joint encoders (CiA 406 style), the UWB
//! gateway and the valve/actuator node. Encoders validate their input, decoders their frame;
//! both return a Result and touch nothing else. All RT-safe: no alloc, no throw.
namespace mgc::hal::pdo {

// --- Joint encoder: TPDO1 (0x180 + node), synchronous (every SYNC), dlc 5 --------------------

//! Whether an encoder measures an angle or a length; it fixes the count's unit.
enum class EncoderKind : std::uint8_t { Rotary, Linear };

inline constexpr double kRotaryDegPerCount = 0.001;  //!< rotary encoder resolution [deg/count]
inline constexpr double kLinearMmPerCount = 0.1;     //!< linear encoder resolution [mm/count]
//! Reserved position value ("not available"); a decoder rejects it.
inline constexpr std::int32_t kEncoderPositionReserved = INT32_MIN;

inline constexpr std::uint8_t kEncoderStatusAlarm = 0x01;    //!< position not valid (6503h alarm)
inline constexpr std::uint8_t kEncoderStatusWarning = 0x02;  //!< position valid, device warns (6505h)
inline constexpr std::uint8_t kEncoderStatusReservedMask = 0xFC;

struct EncoderPosition {
  std::uint8_t node_id = 0;
  std::int32_t position_counts = 0;  //!< 6004h, signed, multi-turn [count]
  std::uint8_t status = 0;           //!< kEncoderStatus* bits
};
[[nodiscard]] Result<CanFrame> encode_encoder_position(const EncoderPosition& message) noexcept;
//! node_id is taken from the frame's COB-ID (a TPDO1 of any node).
[[nodiscard]] Result<EncoderPosition> decode_encoder_position(const CanFrame& frame) noexcept;

//! counts → rad (Rotary) or m (Linear).
[[nodiscard]] double counts_to_si(std::int32_t counts, EncoderKind kind) noexcept;
//! rad or m → nearest count; OutOfRange for NaN, infinities, or beyond int32 (reserved value excluded).
[[nodiscard]] Result<std::int32_t> si_to_counts(double value_si, EncoderKind kind) noexcept;

// --- UWB gateway: TPDO1 (0x180 + node), event-driven (one frame per tag fix), dlc 8 -----------

inline constexpr double kUwbMetresPerCount = 0.01;  //!< coordinate resolution [m/count]
//! Coordinate value that means "no position"; required when quality is 0, refused otherwise.
inline constexpr std::int16_t kUwbNoPosition = INT16_MIN;
inline constexpr std::uint8_t kUwbQualityNoFix = 0;        //!< no position in this frame
inline constexpr std::uint8_t kUwbQualityUnknown = 15;     //!< fix, error worse than 1.4 m or unknown
inline constexpr std::uint8_t kUwbSequenceModulo = 16;     //!< sequence counts 0..15 per tag

struct UwbTagPosition {
  std::uint8_t node_id = 0;
  std::uint8_t tag_id = 0;
  std::array<std::int16_t, 3> position_cm{};  //!< x, y, z in the site frame [cm]
  std::uint8_t sequence = 0;  //!< per tag, +1 per fix, modulo 16
  //! 0 = no fix; 1..14 = 1-sigma error at most quality × 10 cm; 15 = worse or unknown.
  std::uint8_t quality = 0;
};
[[nodiscard]] Result<CanFrame> encode_uwb_tag_position(const UwbTagPosition& message) noexcept;
[[nodiscard]] Result<UwbTagPosition> decode_uwb_tag_position(const CanFrame& frame) noexcept;
//! metres → cm count; OutOfRange beyond ±327.67 m or not finite.
[[nodiscard]] Result<std::int16_t> metres_to_uwb_counts(double value_m) noexcept;

// --- Valve / actuator node --------------------------------------------------------------------

inline constexpr std::size_t kJointsPerValveFrame = 4;
inline constexpr std::size_t kValveBanks = 2;  //!< joints 0-3 and 4-7
//! Full scale of a velocity or spool command: ±10000 = ±100.00 % of the joint's max velocity.
inline constexpr std::int16_t kValveFullScale = 10000;

//! Velocity command for four joints: RPDO1 (0x200 + node) joints 0-3, RPDO2 (0x300 + node)
//! joints 4-7; dlc 8, four LE int16 in 0.01 % of max velocity. Unused joints carry 0.
struct ValveCommand {
  std::uint8_t node_id = 0;
  std::uint8_t bank = 0;  //!< 0: joints 0-3, 1: joints 4-7
  std::array<std::int16_t, kJointsPerValveFrame> velocity_permyriad{};  //!< -10000..10000 [0.01 %]
};
[[nodiscard]] Result<CanFrame> encode_valve_command(const ValveCommand& message) noexcept;
[[nodiscard]] Result<ValveCommand> decode_valve_command(const CanFrame& frame) noexcept;

//! What the valve node is doing with its outputs.
enum class ValveState : std::uint8_t {
  Disabled = 0,  //!< not Operational: every spool neutral, commands ignored
  Active = 1,    //!< following commands
  FailSafe = 2,  //!< brought every spool to neutral after a loss; needs a new NMT Start
  Fault = 3,     //!< internal fault: spools neutral (solenoids off)
};
//! Why the node is in FailSafe or Fault.
enum class ValveReason : std::uint8_t {
  None = 0,
  ControllerHeartbeatLost = 1,
  CommandTimeout = 2,
  InternalFault = 3,
};

//! Valve status: TPDO1 (0x180 + node), synchronous, dlc 4.
struct ValveStatus {
  std::uint8_t node_id = 0;
  ValveState state = ValveState::Disabled;
  ValveReason reason = ValveReason::None;
  std::uint8_t joint_fault_mask = 0;  //!< bit n: joint n's spool or actuator is faulted
  std::uint8_t command_counter = 0;   //!< valid command frames received, modulo 256 [frames]
};
[[nodiscard]] Result<CanFrame> encode_valve_status(const ValveStatus& message) noexcept;
[[nodiscard]] Result<ValveStatus> decode_valve_status(const CanFrame& frame) noexcept;

//! Spool commands actually applied (after the node's ramps and fail-safe), same scaling as
//! ValveCommand: TPDO2 (0x280 + node) joints 0-3, TPDO3 (0x380 + node) joints 4-7; synchronous, dlc 8.
struct ValveApplied {
  std::uint8_t node_id = 0;
  std::uint8_t bank = 0;
  std::array<std::int16_t, kJointsPerValveFrame> velocity_permyriad{};  //!< -10000..10000 [0.01 %]
};
[[nodiscard]] Result<CanFrame> encode_valve_applied(const ValveApplied& message) noexcept;
[[nodiscard]] Result<ValveApplied> decode_valve_applied(const CanFrame& frame) noexcept;

// --- Pilot-pressure cut-off node: the second shut-off channel ---------------------------------
//
// A dump valve in the pilot supply of the main valve block: without pilot pressure every main
// spool springs to neutral, whatever the valve node commands. De-energised means cut, so the
// node needs a fresh enable command to keep the pressure on (docs/protocol.md §Cut-off node).

//! What the controller asks of the cut-off: RPDO1 (0x200 + node), every cycle, dlc 1.
enum class PilotCommand : std::uint8_t {
  Cut = 0x00,     //!< dump the pilot supply
  Enable = 0xA5,  //!< keep it pressurised; a pattern, so that one corrupt bit never enables
};
struct CutoffCommand {
  std::uint8_t node_id = 0;
  PilotCommand command = PilotCommand::Cut;
};
[[nodiscard]] Result<CanFrame> encode_cutoff_command(const CutoffCommand& message) noexcept;
//! OutOfRange for any command byte other than the two patterns.
[[nodiscard]] Result<CutoffCommand> decode_cutoff_command(const CanFrame& frame) noexcept;

enum class CutoffState : std::uint8_t {
  Cut = 0,      //!< the dump valve is open (commanded, not started, or after a loss)
  Enabled = 1,  //!< the dump valve is closed: pilot pressure is supplied
  Fault = 2,    //!< internal fault: the node de-energised its output
};
//! Why the node holds the pilot cut.
enum class CutoffReason : std::uint8_t {
  None = 0,                     //!< Enabled
  Commanded = 1,                //!< the controller asked for the cut (or has not enabled yet)
  NotOperational = 2,           //!< the node is not in NMT Operational
  ControllerHeartbeatLost = 3,  //!< latched until the next NMT Start
  CommandTimeout = 4,           //!< no enable command for the RPDO timeout; latched until NMT Start
  InternalFault = 5,
};
//! Cut-off status: TPDO1 (0x180 + node), synchronous, dlc 3: state, reason, and the pilot pressure
//! switch downstream of the dump valve (1 = pressure present): the node reports what the
//! hydraulics do, not what it asked of them.
struct CutoffStatus {
  std::uint8_t node_id = 0;
  CutoffState state = CutoffState::Cut;
  CutoffReason reason = CutoffReason::Commanded;
  bool pressure = false;
};
[[nodiscard]] Result<CanFrame> encode_cutoff_status(const CutoffStatus& message) noexcept;
[[nodiscard]] Result<CutoffStatus> decode_cutoff_status(const CanFrame& frame) noexcept;

//! Fraction of max velocity (-1..1) → command count; OutOfRange outside [-1, 1] or NaN.
[[nodiscard]] Result<std::int16_t> fraction_to_permyriad(double fraction) noexcept;
[[nodiscard]] constexpr double permyriad_to_fraction(std::int16_t permyriad) noexcept {
  return static_cast<double>(permyriad) / kValveFullScale;
}

}  // namespace mgc::hal::pdo

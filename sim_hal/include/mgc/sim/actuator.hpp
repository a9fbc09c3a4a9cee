// SPDX-License-Identifier: Apache-2.0
#pragma once

namespace mgc::sim {

//! One joint's hydraulic drive as the simulator models it: a proportional valve with a deadband
//! feeding a cylinder or motor whose velocity follows the valve's flow with a first-order lag,
//! limited in acceleration and velocity, stopped by the joint's end stops. docs/simulator.md.
struct ActuatorParams {
  double max_velocity = 0.0;      //!< at 100 % spool [rad/s | m/s]
  double max_acceleration = 0.0;  //!< [rad/s^2 | m/s^2]
  double lag_s = 0.15;            //!< flow-to-velocity time constant [s]
  double deadband = 0.03;         //!< spool fraction below which no oil flows [-]
  double position_min = 0.0;      //!< end stop [rad | m]
  double position_max = 0.0;      //!< end stop [rad | m]
  bool continuous = false;        //!< no end stops (a slew ring)
};

class HydraulicActuator {
 public:
  HydraulicActuator() = default;
  HydraulicActuator(const ActuatorParams& params, double position) noexcept : params_(params), position_(position) {}

  //! The velocity the valve asks for at this spool fraction (-1..1): zero inside the deadband,
  //! then linear up to max_velocity at full spool. [rad/s | m/s]
  [[nodiscard]] double target_velocity(double spool_fraction) const noexcept;

  //! Advances by dt_s with the spool held at spool_fraction. RT-safe.
  void step(double spool_fraction, double dt_s) noexcept;

  //! Moves the joint by delta outside its drive (a creep the valve does not cause), stopped by the
  //! end stops. RT-safe.
  void displace(double delta) noexcept;

  [[nodiscard]] double position() const noexcept { return position_; }        //!< [rad | m]
  [[nodiscard]] double velocity() const noexcept { return velocity_; }        //!< [rad/s | m/s]
  [[nodiscard]] double acceleration() const noexcept { return acceleration_; }  //!< of the last step
  [[nodiscard]] const ActuatorParams& params() const noexcept { return params_; }

 private:
  ActuatorParams params_{};
  double position_ = 0.0;
  double velocity_ = 0.0;
  double acceleration_ = 0.0;
};

}  // namespace mgc::sim

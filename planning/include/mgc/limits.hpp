// SPDX-License-Identifier: Apache-2.0
#pragma once

//! Compile-time capacities of everything the control loop and the planners touch.
//! A full container is a reported fault, never a silent drop.
namespace mgc {

inline constexpr int kMaxJoints = 8;         //!< joints of one planning problem (dual crane: 6)
inline constexpr int kMaxBodies = 12;        //!< collision bodies of one machine model
inline constexpr int kMaxFrames = 12;        //!< kinematic frames reported by forward kinematics
inline constexpr int kMaxKeyPoints = 8;      //!< named points (boom tip, hook, bucket tip, ...)
inline constexpr int kMaxSelfPairs = 32;     //!< body pairs of one machine checked against each other (dual crane: 25)

}  // namespace mgc

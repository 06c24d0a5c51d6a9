// Conversions between the planner's frames and MAVLink's.
//
// QuadHand: world ENU (x east, y north, z up), body FLU (x forward, y left,
//   z up); yaw measured from east, counter-clockwise seen from above.
// MAVLink:  local NED (x north, y east, z down), body FRD (x forward, y right,
//   z down); yaw measured from north, clockwise seen from above.
//
// Quaternions are Hamilton, body-to-world in both conventions: a QuadHand
// attitude maps FLU body vectors into ENU, a MAVLink attitude
// (ATTITUDE_QUATERNION q1..q4 = w, x, y, z) maps FRD body vectors into NED.
// Each conversion comes with its inverse: converting there and back returns
// the input (up to rounding, and angle wrapping for yaw).
#pragma once

#include "quadhand/core/types.h"

namespace quadhand::link {

// World vectors (positions in m, velocities in m/s, accelerations in m/s^2):
// (e, n, u) <-> (n, e, -u). The map is its own inverse.
Vec3 EnuToNed(const Vec3& v_enu);
Vec3 NedToEnu(const Vec3& v_ned);

// Body vectors (angular rates in rad/s, forces): (f, l, u) <-> (f, -l, -u).
Vec3 FluToFrd(const Vec3& v_flu);
Vec3 FrdToFlu(const Vec3& v_frd);

// Attitudes: q_ENU_FLU (FLU -> ENU) <-> q_NED_FRD (FRD -> NED). The result is
// normalised and has w >= 0 (q and -q are the same rotation).
Quat AttitudeEnuFluToNedFrd(const Quat& q_enu_flu);
Quat AttitudeNedFrdToEnuFlu(const Quat& q_ned_frd);

// Yaw angles in rad: yaw_ned = pi/2 - yaw_enu, wrapped to [-pi, pi).
// (Yaw rates are body z rates: use FluToFrd, or simply negate.)
double YawEnuToNed(double yaw_enu);
double YawNedToEnu(double yaw_ned);

// An angle wrapped to [-pi, pi).
double WrapAngle(double angle);

}  // namespace quadhand::link

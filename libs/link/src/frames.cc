// ENU/FLU <-> NED/FRD conversions (see frames.h).
#include "quadhand/link/frames.h"

#include <cmath>

namespace quadhand::link {
namespace {

// NED <- ENU: the 180 degree rotation about the axis (1, 1, 0)/sqrt(2), which
// swaps x and y and negates z.
const Quat& NedFromEnu() {
  static const Quat q(0.0, M_SQRT1_2, M_SQRT1_2, 0.0);
  return q;
}

// FLU <- FRD (and FRD <- FLU): the 180 degree rotation about body x.
const Quat& FluFromFrd() {
  static const Quat q(0.0, 1.0, 0.0, 0.0);
  return q;
}

Quat Canonical(Quat q) {
  q.normalize();
  if (q.w() < 0.0) q.coeffs() *= -1.0;
  return q;
}

}  // namespace

Vec3 EnuToNed(const Vec3& v_enu) { return Vec3(v_enu.y(), v_enu.x(), -v_enu.z()); }
Vec3 NedToEnu(const Vec3& v_ned) { return Vec3(v_ned.y(), v_ned.x(), -v_ned.z()); }

Vec3 FluToFrd(const Vec3& v_flu) { return Vec3(v_flu.x(), -v_flu.y(), -v_flu.z()); }
Vec3 FrdToFlu(const Vec3& v_frd) { return Vec3(v_frd.x(), -v_frd.y(), -v_frd.z()); }

Quat AttitudeEnuFluToNedFrd(const Quat& q_enu_flu) {
  // R_NED_FRD = R_NED_ENU * R_ENU_FLU * R_FLU_FRD.
  return Canonical(NedFromEnu() * q_enu_flu * FluFromFrd());
}

Quat AttitudeNedFrdToEnuFlu(const Quat& q_ned_frd) {
  // R_ENU_FLU = R_ENU_NED * R_NED_FRD * R_FRD_FLU; both constant rotations
  // are half turns, hence their own inverses.
  return Canonical(NedFromEnu() * q_ned_frd * FluFromFrd());
}

double WrapAngle(double angle) {
  const double two_pi = 2.0 * M_PI;
  double wrapped = std::fmod(angle + M_PI, two_pi);
  if (wrapped < 0.0) wrapped += two_pi;
  return wrapped - M_PI;
}

double YawEnuToNed(double yaw_enu) { return WrapAngle(M_PI_2 - yaw_enu); }
double YawNedToEnu(double yaw_ned) { return WrapAngle(M_PI_2 - yaw_ned); }

}  // namespace quadhand::link

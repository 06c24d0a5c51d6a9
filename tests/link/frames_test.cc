// ENU/FLU <-> NED/FRD conversions: known cases and round trips.
#include <gtest/gtest.h>

#include <cmath>

#include "quadhand/link/frames.h"

namespace quadhand::link {
namespace {

constexpr double kTol = 1e-12;

Quat YawEnu(double yaw) { return Quat(Eigen::AngleAxisd(yaw, Vec3::UnitZ())); }

// Angle between two rotations (q and -q are equal).
double RotationDistance(const Quat& a, const Quat& b) { return a.angularDistance(b); }

TEST(FramesTest, WorldVectorsSwapNorthEastAndFlipUp) {
  EXPECT_TRUE(EnuToNed(Vec3(1, 2, 3)).isApprox(Vec3(2, 1, -3)));
  EXPECT_TRUE(NedToEnu(Vec3(2, 1, -3)).isApprox(Vec3(1, 2, 3)));
  const Vec3 v(-0.3, 4.5, 7.25);
  EXPECT_LT((NedToEnu(EnuToNed(v)) - v).norm(), kTol);
}

TEST(FramesTest, BodyVectorsFlipLeftAndUp) {
  EXPECT_TRUE(FluToFrd(Vec3(1, 2, 3)).isApprox(Vec3(1, -2, -3)));
  const Vec3 rates(0.1, -0.2, 0.3);
  EXPECT_LT((FrdToFlu(FluToFrd(rates)) - rates).norm(), kTol);
}

TEST(FramesTest, FacingEastAndNorth) {
  // Facing east: ENU yaw 0, NED yaw +pi/2.
  EXPECT_NEAR(YawEnuToNed(0.0), M_PI_2, kTol);
  const Quat east = AttitudeEnuFluToNedFrd(Quat::Identity());
  EXPECT_LT(RotationDistance(east, Quat(Eigen::AngleAxisd(M_PI_2, Vec3::UnitZ()))), 1e-12);
  // Facing north: ENU yaw pi/2, NED yaw 0 (identity attitude in NED/FRD).
  EXPECT_NEAR(YawEnuToNed(M_PI_2), 0.0, kTol);
  const Quat north = AttitudeEnuFluToNedFrd(YawEnu(M_PI_2));
  EXPECT_LT(RotationDistance(north, Quat::Identity()), 1e-12);
  EXPECT_GE(north.w(), 0.0);
  // Facing west: ENU yaw pi, NED yaw -pi/2 (wrapped into [-pi, pi)).
  EXPECT_NEAR(YawEnuToNed(M_PI), -M_PI_2, kTol);
  // Facing south: NED yaw pi, which wraps to -pi.
  EXPECT_NEAR(std::abs(YawEnuToNed(-M_PI_2)), M_PI, kTol);
}

TEST(FramesTest, AttitudeMapsBodyAxesConsistently) {
  // Whatever the attitude, the body forward axis must point the same way in
  // both conventions, and so must the body up (-down) axis.
  const Quat q_enu = Quat(Eigen::AngleAxisd(0.7, Vec3(1, -2, 0.5).normalized()));
  const Quat q_ned = AttitudeEnuFluToNedFrd(q_enu);
  const Vec3 forward_enu = q_enu * Vec3::UnitX();
  const Vec3 forward_ned = q_ned * Vec3::UnitX();
  EXPECT_LT((EnuToNed(forward_enu) - forward_ned).norm(), 1e-12);
  const Vec3 left_enu = q_enu * Vec3::UnitY();
  const Vec3 right_ned = q_ned * Vec3::UnitY();
  EXPECT_LT((EnuToNed(left_enu) + right_ned).norm(), 1e-12);
  // Yaw extracted from the NED attitude equals the converted ENU yaw for a pure yaw.
  const double yaw_enu = 0.4;
  const Quat q = AttitudeEnuFluToNedFrd(YawEnu(yaw_enu));
  const Vec3 f = q * Vec3::UnitX();
  EXPECT_NEAR(std::atan2(f.y(), f.x()), YawEnuToNed(yaw_enu), 1e-12);
}

TEST(FramesTest, ARollIsTheSameRollInBothConventions) {
  // Right wing down is a positive roll about forward x in FRD; x is forward
  // in FLU too, so it is the same positive rotation there (the left wing goes up).
  const double roll = 0.3;
  const Quat q_ned = Quat(Eigen::AngleAxisd(roll, Vec3::UnitX()));  // facing north, rolled right
  const Quat q_enu = AttitudeNedFrdToEnuFlu(q_ned);
  const Vec3 right_ned = q_ned * Vec3::UnitY();
  EXPECT_GT(right_ned.z(), 0.0);  // right wing down (z down)
  const Vec3 left_enu = q_enu * Vec3::UnitY();
  EXPECT_GT(left_enu.z(), 0.0);  // so the left wing is up
  // Facing north in ENU with a rotation of +roll about body x (FLU).
  const Quat expected = YawEnu(M_PI_2) * Quat(Eigen::AngleAxisd(roll, Vec3::UnitX()));
  EXPECT_LT(RotationDistance(q_enu, expected), 1e-12);
  // The body rate of that roll: +p in both (x is forward in both frames).
  EXPECT_NEAR(FluToFrd(Vec3(0.5, 0, 0)).x(), 0.5, kTol);
}

TEST(FramesTest, RoundTrips) {
  for (int i = 0; i < 50; ++i) {
    const Vec3 axis = Vec3(std::sin(i), std::cos(3 * i), std::sin(0.5 * i) + 0.1).normalized();
    const Quat q(Eigen::AngleAxisd(0.13 * i - 3.0, axis));
    EXPECT_LT(RotationDistance(AttitudeNedFrdToEnuFlu(AttitudeEnuFluToNedFrd(q)), q), 1e-12);
    const double yaw = -7.0 + 0.29 * i;
    EXPECT_NEAR(WrapAngle(YawNedToEnu(YawEnuToNed(yaw)) - yaw), 0.0, 1e-12);
    const double wrapped = WrapAngle(yaw);
    EXPECT_GE(wrapped, -M_PI);
    EXPECT_LT(wrapped, M_PI);
    EXPECT_NEAR(std::remainder(wrapped - yaw, 2 * M_PI), 0.0, 1e-12);
  }
}

}  // namespace
}  // namespace quadhand::link

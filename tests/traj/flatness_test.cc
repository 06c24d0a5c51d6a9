// Quadrotor flatness with the Hopf-fibration attitude: exact values, body rate
// against a numerically differentiated attitude, backward pass against finite
// differences, and the singular cases.
//
// Error measure (numeric_diff.h): max_i |analytic_i - fd_i| / max_i |fd_i|,
// 5-point central differences with step 1e-4 * max(1, |x_i|), bound 1e-7; the
// backward test also checks 3-point central differences (step 1e-6), bound 1e-6.
#include "quadhand/traj/flatness.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "traj/numeric_diff.h"

namespace quadhand::traj {
namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;
using Eigen::Vector4d;
using Eigen::VectorXd;
using testing::NumericGradient;
using testing::RelativeError;
using testing::Sci;

constexpr double kG = 9.81;
constexpr double kBound = 1e-7;
constexpr double kStep = 1e-4;

Vector3d Vee(const Matrix3d& m) { return Vector3d(m(2, 1), m(0, 2), m(1, 0)); }

// x = [v (3), a (3), j (3), psi, psi_dot].
struct Input {
  Vector3d v, a, j;
  double psi, psi_dot;
};
Input Unpack(const VectorXd& x) {
  return {x.segment<3>(0), x.segment<3>(3), x.segment<3>(6), x[9], x[10]};
}
VectorXd Pack(const Input& in) {
  VectorXd x(11);
  x << in.v, in.a, in.j, in.psi, in.psi_dot;
  return x;
}

double Loss(const FlatState& st, const FlatStateGrad& w) {
  return w.thrust * st.thrust + w.quat.dot(st.quat) + w.body_rate.dot(st.body_rate) +
         w.body_rate_xy_sq * st.body_rate_xy_sq;
}

VectorXd AnalyticGradient(const VectorXd& x, const FlatStateGrad& w) {
  const Input in = Unpack(x);
  const FlatState st = FlatForward(in.v, in.a, in.j, in.psi, in.psi_dot);
  const FlatInputGrad g = FlatBackward(in.v, in.a, in.j, in.psi, in.psi_dot, st, w);
  VectorXd out(11);
  out << g.vel, g.acc, g.jerk, g.yaw, g.yaw_rate;
  return out;
}

VectorXd FiniteDifferenceGradient(const VectorXd& x, const FlatStateGrad& w) {
  return NumericGradient(
      [&](const VectorXd& y) {
        const Input in = Unpack(y);
        return Loss(FlatForward(in.v, in.a, in.j, in.psi, in.psi_dot), w);
      },
      x, kStep);
}

TEST(FlatnessTest, HoverIsIdentityAttitude) {
  const FlatState st = FlatForward(Vector3d::Zero(), Vector3d::Zero(), Vector3d::Zero(), 0.0, 0.0);
  EXPECT_EQ(st.status, FlatnessStatus::kOk);
  EXPECT_DOUBLE_EQ(st.thrust, kG);
  EXPECT_LT((st.quat - Vector4d(1, 0, 0, 0)).norm(), 1e-15);
  EXPECT_LT(st.body_rate.norm(), 1e-15);
  EXPECT_EQ(st.body_rate_xy_sq, 0.0);
  EXPECT_LT((st.rotation() - Matrix3d::Identity()).norm(), 1e-15);
}

TEST(FlatnessTest, HoverWithYawIsYawRotation) {
  for (double psi : {0.3, -1.2, 2.9, 4.0}) {
    const FlatState st =
        FlatForward(Vector3d(1, 2, 0), Vector3d::Zero(), Vector3d::Zero(), psi, 0.7);
    EXPECT_LT((st.quat - Vector4d(std::cos(psi / 2), 0, 0, std::sin(psi / 2))).norm(), 1e-15);
    const Matrix3d expected = Eigen::AngleAxisd(psi, Vector3d::UnitZ()).toRotationMatrix();
    EXPECT_LT((st.rotation() - expected).norm(), 1e-14);
    EXPECT_LT((st.body_rate - Vector3d(0, 0, 0.7)).norm(), 1e-15);
  }
}

// a = (g, 0, 0): thrust g sqrt(2), body z = (1, 0, 1)/sqrt(2): a 45 degree pitch about +y.
TEST(FlatnessTest, KnownTiltedAttitude) {
  const FlatState st =
      FlatForward(Vector3d::Zero(), Vector3d(kG, 0, 0), Vector3d::Zero(), 0.0, 0.0);
  EXPECT_NEAR(st.thrust, kG * std::sqrt(2.0), 1e-14);
  EXPECT_LT((st.z_body - Vector3d(1, 0, 1) / std::sqrt(2.0)).norm(), 1e-15);
  const double half = M_PI / 8.0;
  EXPECT_LT((st.quat - Vector4d(std::cos(half), 0, std::sin(half), 0)).norm(), 1e-15);
  const Matrix3d expected = Eigen::AngleAxisd(M_PI / 4, Vector3d::UnitY()).toRotationMatrix();
  EXPECT_LT((st.rotation() - expected).norm(), 1e-15);

  // Same tilt with yaw pi/2: R = R_y(pi/4) R_z(pi/2); the body x axis points along +y.
  const FlatState yawed =
      FlatForward(Vector3d::Zero(), Vector3d(kG, 0, 0), Vector3d::Zero(), M_PI / 2, 0.0);
  const Matrix3d expected_yawed =
      expected * Eigen::AngleAxisd(M_PI / 2, Vector3d::UnitZ()).toRotationMatrix();
  EXPECT_LT((yawed.rotation() - expected_yawed).norm(), 1e-15);
}

// Along a smooth acceleration profile, omega must equal vee(R^T dR/dt) of the attitude.
TEST(FlatnessTest, BodyRateMatchesDifferentiatedAttitude) {
  auto acc = [](double t) {
    return Vector3d(6.0 * std::sin(1.3 * t), -4.0 * std::cos(0.7 * t), 5.0 * std::sin(0.9 * t));
  };
  auto jerk = [](double t) {
    return Vector3d(7.8 * std::cos(1.3 * t), 2.8 * std::sin(0.7 * t), 4.5 * std::cos(0.9 * t));
  };
  auto yaw = [](double t) { return 0.4 + 2.0 * std::sin(0.8 * t); };
  auto yaw_rate = [](double t) { return 1.6 * std::cos(0.8 * t); };
  auto rot = [&](double t) {
    return FlatForward(Vector3d::Zero(), acc(t), jerk(t), yaw(t), yaw_rate(t)).rotation();
  };
  for (double t = 0.0; t < 8.0; t += 0.173) {
    const FlatState st = FlatForward(Vector3d::Zero(), acc(t), jerk(t), yaw(t), yaw_rate(t));
    ASSERT_EQ(st.status, FlatnessStatus::kOk);
    const double h = 1e-3;
    const Matrix3d r_dot =
        (8.0 * (rot(t + h) - rot(t - h)) - (rot(t + 2 * h) - rot(t - 2 * h))) / (12.0 * h);
    const Vector3d omega_numeric = Vee(st.rotation().transpose() * r_dot);
    EXPECT_LT((st.body_rate - omega_numeric).norm(), 1e-8 * std::max(1.0, omega_numeric.norm()))
        << "t = " << t;
    EXPECT_NEAR(st.body_rate_xy_sq, st.body_rate.head<2>().squaredNorm(), 1e-12);
    EXPECT_NEAR(st.body_rate_xy_sq, st.z_body_dot.squaredNorm(), 1e-15);
    EXPECT_LT((st.rotation().col(2) - st.z_body).norm(), 1e-14);
    EXPECT_NEAR(st.quat.norm(), 1.0, 1e-15);
  }
}

FlatStateGrad RandomWeights(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  FlatStateGrad w;
  w.thrust = u(rng);
  w.quat = Vector4d(u(rng), u(rng), u(rng), u(rng));
  w.body_rate = Vector3d(u(rng), u(rng), u(rng));
  w.body_rate_xy_sq = u(rng);
  return w;
}

// Each output on its own, then all together, at random points including large tilts.
TEST(FlatnessTest, BackwardMatchesFiniteDifferences) {
  std::mt19937 rng(123);
  std::uniform_real_distribution<double> ua(-15.0, 15.0), uj(-20.0, 20.0), up(-3.5, 3.5);
  double worst = 0.0, worst3 = 0.0;
  int checked = 0;
  while (checked < 300) {
    const Input in{Vector3d(ua(rng), ua(rng), ua(rng)), Vector3d(ua(rng), ua(rng), ua(rng)),
                   Vector3d(uj(rng), uj(rng), uj(rng)), up(rng), up(rng)};
    const FlatState st = FlatForward(in.v, in.a, in.j, in.psi, in.psi_dot);
    if (st.status != FlatnessStatus::kOk || 1.0 + st.z_body.z() < 0.05 || st.thrust < 1.0) continue;
    ++checked;
    const VectorXd x = Pack(in);
    const FlatStateGrad all = RandomWeights(rng);
    FlatStateGrad parts[5];
    parts[0].thrust = all.thrust;
    parts[1].quat = all.quat;
    parts[2].body_rate = all.body_rate;
    parts[3].body_rate_xy_sq = all.body_rate_xy_sq;
    parts[4] = all;
    const char* names[5] = {"thrust", "quaternion", "body rate", "|omega_xy|^2", "all"};
    for (int k = 0; k < 5; ++k) {
      const VectorXd analytic = AnalyticGradient(x, parts[k]);
      const VectorXd numeric = FiniteDifferenceGradient(x, parts[k]);
      const double err = RelativeError(analytic, numeric);
      worst = std::max(worst, err);
      EXPECT_LT(err, kBound) << names[k] << " at a = " << in.a.transpose()
                             << "\nanalytic " << analytic.transpose()
                             << "\nnumeric  " << numeric.transpose();
      EXPECT_EQ(analytic.head<3>().norm(), 0.0);  // no drag: velocity does not matter
      const VectorXd numeric3 = NumericGradient(
          [&](const VectorXd& y) {
            const Input i3 = Unpack(y);
            return Loss(FlatForward(i3.v, i3.a, i3.j, i3.psi, i3.psi_dot), parts[k]);
          },
          x, 1e-6, 3);
      worst3 = std::max(worst3, RelativeError(analytic, numeric3));
    }
  }
  RecordProperty("rel_error_5pt", Sci(worst));
  RecordProperty("rel_error_3pt", Sci(worst3));
  EXPECT_LT(worst3, 1e-6);  // plain 3-point central differences, step 1e-6
}

void ExpectFinite(const FlatState& st, const FlatInputGrad& g) {
  EXPECT_TRUE(std::isfinite(st.thrust));
  EXPECT_TRUE(st.quat.allFinite());
  EXPECT_TRUE(st.body_rate.allFinite());
  EXPECT_TRUE(st.z_body.allFinite());
  EXPECT_TRUE(st.z_body_dot.allFinite());
  EXPECT_TRUE(std::isfinite(st.body_rate_xy_sq));
  EXPECT_NEAR(st.quat.norm(), 1.0, 1e-14);
  EXPECT_TRUE(g.acc.allFinite());
  EXPECT_TRUE(g.jerk.allFinite());
  EXPECT_TRUE(std::isfinite(g.yaw));
  EXPECT_TRUE(std::isfinite(g.yaw_rate));
}

TEST(FlatnessTest, FreeFallIsFlaggedAndFinite) {
  std::mt19937 rng(5);
  const FlatStateGrad w = RandomWeights(rng);
  const Vector3d j(3.0, -2.0, 1.0);
  // Exact free fall: f = 0.
  const Vector3d a(0, 0, -kG);
  FlatState st = FlatForward(Vector3d::Zero(), a, j, 0.8, 0.4);
  FlatInputGrad g = FlatBackward(Vector3d::Zero(), a, j, 0.8, 0.4, st, w);
  EXPECT_EQ(st.status, FlatnessStatus::kFreeFall);
  EXPECT_STREQ(FlatnessStatusName(st.status), "free fall");
  ExpectFinite(st, g);
  EXPECT_EQ(st.thrust, 0.0);
  EXPECT_LT((st.quat - Vector4d(std::cos(0.4), 0, 0, std::sin(0.4))).norm(), 1e-15);
  EXPECT_LT((st.body_rate - Vector3d(0, 0, 0.4)).norm(), 1e-15);
  EXPECT_EQ(st.body_rate_xy_sq, 0.0);
  EXPECT_EQ(g.acc.norm(), 0.0);
  EXPECT_EQ(g.jerk.norm(), 0.0);
  EXPECT_EQ(g.yaw_rate, w.body_rate.z());
  // The fallback q_z(psi) is differentiated exactly in psi.
  const double h = 1e-6;
  const double fd_yaw =
      (Loss(FlatForward(Vector3d::Zero(), a, j, 0.8 + h, 0.4), w) -
       Loss(FlatForward(Vector3d::Zero(), a, j, 0.8 - h, 0.4), w)) / (2 * h);
  EXPECT_NEAR(g.yaw, fd_yaw, 1e-8);

  // Just below the threshold: the thrust gradient is the unit direction of a + g e3.
  const Vector3d a2(0.0, 4e-4, -kG);
  st = FlatForward(Vector3d::Zero(), a2, j, 0.0, 0.0);
  g = FlatBackward(Vector3d::Zero(), a2, j, 0.0, 0.0, st, w);
  EXPECT_EQ(st.status, FlatnessStatus::kFreeFall);
  ExpectFinite(st, g);
  EXPECT_LT((g.acc - w.thrust * Vector3d::UnitY()).norm(), 1e-12);
}

TEST(FlatnessTest, InvertedIsFlaggedAndFinite) {
  std::mt19937 rng(6);
  const FlatStateGrad w = RandomWeights(rng);
  const Vector3d j(1.0, 2.0, -0.5);
  for (const Vector3d& a : {Vector3d(0, 0, -2 * kG), Vector3d(1e-4, -2e-4, -2 * kG)}) {
    const FlatState st = FlatForward(Vector3d::Zero(), a, j, 0.3, -0.2);
    const FlatInputGrad g = FlatBackward(Vector3d::Zero(), a, j, 0.3, -0.2, st, w);
    EXPECT_EQ(st.status, FlatnessStatus::kNearInverted);
    ExpectFinite(st, g);
    EXPECT_NEAR(st.thrust, kG, 1e-6);
    EXPECT_NEAR(st.body_rate_xy_sq, st.z_body_dot.squaredNorm(), 1e-15);
    // The attitude stays close to the true one: its z axis is within the tolerance.
    EXPECT_LT((st.rotation().col(2) - st.z_body).norm(), 0.02);

    // Thrust and |omega_xy|^2 keep exact gradients in the inverted case.
    FlatStateGrad exact;
    exact.thrust = w.thrust;
    exact.body_rate_xy_sq = w.body_rate_xy_sq;
    const VectorXd x = Pack({Vector3d::Zero(), a, j, 0.3, -0.2});
    EXPECT_LT(RelativeError(AnalyticGradient(x, exact), FiniteDifferenceGradient(x, exact)), 1e-6);
  }
  // Exactly -e3: the chart point uses the +x azimuth.
  const FlatState st = FlatForward(Vector3d::Zero(), Vector3d(0, 0, -2 * kG), j, 0.0, 0.0);
  EXPECT_GT(st.rotation().col(2).x(), 0.0);
  EXPECT_STREQ(FlatnessStatusName(st.status), "near inverted");
}

// Near (but outside) the inverted tolerance, outputs and gradients remain finite and correct.
TEST(FlatnessTest, LargeTiltStillAccurate) {
  std::mt19937 rng(8);
  const FlatStateGrad w = RandomWeights(rng);
  // z close to -e3 with 1 + c around 1e-2.
  const Vector3d a(2.0, 1.0, -2 * kG - 9.0);
  const Vector3d j(0.5, -0.3, 0.2);
  const FlatState st = FlatForward(Vector3d::Zero(), a, j, 0.7, 0.1);
  ASSERT_EQ(st.status, FlatnessStatus::kOk);
  ASSERT_LT(1.0 + st.z_body.z(), 0.05);
  const VectorXd x = Pack({Vector3d::Zero(), a, j, 0.7, 0.1});
  EXPECT_LT(RelativeError(AnalyticGradient(x, w), FiniteDifferenceGradient(x, w)), 1e-6);
}

}  // namespace
}  // namespace quadhand::traj

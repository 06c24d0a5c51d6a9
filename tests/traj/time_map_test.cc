// Time map tau <-> T: values, smoothness at 0, inverse, derivatives by finite differences.
#include "quadhand/traj/time_map.h"

#include <cfloat>
#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "traj/numeric_diff.h"

namespace quadhand::traj {
namespace {

using Eigen::VectorXd;
using testing::NumericGradient;
using testing::RelativeError;

// Same measure as every gradient test (see numeric_diff.h).
constexpr double kBound = 1e-7;

TEST(TimeMapTest, KnownValues) {
  EXPECT_DOUBLE_EQ(TimeFromTau(0.0), 1.0);
  EXPECT_DOUBLE_EQ(TimeFromTau(2.0), 5.0);          // 1 + 2 + 2
  EXPECT_DOUBLE_EQ(TimeFromTau(-2.0), 1.0 / 5.0);   // 1 / (1 + 2 + 2)
  EXPECT_DOUBLE_EQ(TimeDerivative(0.0), 1.0);
  EXPECT_DOUBLE_EQ(TimeDerivative(2.0), 3.0);
  EXPECT_DOUBLE_EQ(TimeDerivative(-2.0), 3.0 / 25.0);
  EXPECT_DOUBLE_EQ(TauFromTime(1.0), 0.0);
  EXPECT_NEAR(TauFromTime(5.0), 2.0, 1e-15);
  EXPECT_NEAR(TauFromTime(0.2), -2.0, 1e-14);
}

TEST(TimeMapTest, StrictlyIncreasingAndPositive) {
  double prev = 0.0;
  for (double tau = -50.0; tau <= 50.0; tau += 0.01) {
    const double t = TimeFromTau(tau);
    EXPECT_GT(t, prev);
    EXPECT_GT(TimeDerivative(tau), 0.0);
    prev = t;
  }
}

// C^2 at tau = 0: value, first and second derivative agree from both sides.
TEST(TimeMapTest, SmoothAtZero) {
  const double e = 1e-7;
  EXPECT_NEAR(TimeFromTau(e), TimeFromTau(-e), 3e-7);
  EXPECT_NEAR(TimeDerivative(e), TimeDerivative(-e), 3e-7);
  const double h = 1e-4;
  const double second_right = (TimeDerivative(2 * h) - TimeDerivative(h)) / h;
  const double second_left = (TimeDerivative(-h) - TimeDerivative(-2 * h)) / h;
  EXPECT_NEAR(second_right, 1.0, 1e-3);
  EXPECT_NEAR(second_left, 1.0, 1e-3);
}

TEST(TimeMapTest, InverseRoundTrips) {
  for (double tau = -30.0; tau <= 30.0; tau += 0.37) {
    EXPECT_NEAR(TauFromTime(TimeFromTau(tau)), tau, 1e-10 * std::max(1.0, std::abs(tau)));
  }
  for (double t : {1e-6, 1e-3, 0.05, 0.5, 0.999, 1.0, 1.001, 3.0, 100.0, 1e6}) {
    EXPECT_NEAR(TimeFromTau(TauFromTime(t)), t, 1e-12 * t);
  }
}

TEST(TimeMapTest, InverseClampsInvalidTimes) {
  const double floor_tau = TauFromTime(kMinTimeForInverse);
  EXPECT_TRUE(std::isfinite(floor_tau));
  EXPECT_EQ(TauFromTime(0.0), floor_tau);
  EXPECT_EQ(TauFromTime(-3.0), floor_tau);
  EXPECT_EQ(TauFromTime(std::nan("")), floor_tau);
  EXPECT_TRUE(std::isfinite(TauFromTime(INFINITY)));
  EXPECT_TRUE(std::isfinite(TauFromTime(DBL_MAX)));
}

TEST(TimeMapTest, DerivativesMatchFiniteDifferences) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-4.0, 4.0);
  for (int trial = 0; trial < 200; ++trial) {
    const VectorXd tau = VectorXd::Constant(1, u(rng));
    const VectorXd fd = NumericGradient([](const VectorXd& x) { return TimeFromTau(x[0]); }, tau,
                                        1e-3);
    EXPECT_LT(RelativeError(VectorXd::Constant(1, TimeDerivative(tau[0])), fd), kBound)
        << "tau = " << tau[0];

    // Inverse: d tau / dT = 1 / T'(tau).
    const VectorXd t = VectorXd::Constant(1, TimeFromTau(tau[0]));
    const VectorXd fd_inv = NumericGradient(
        [](const VectorXd& x) { return TauFromTime(x[0]); }, t, 1e-4 * std::min(1.0, t[0]));
    EXPECT_LT(RelativeError(VectorXd::Constant(1, 1.0 / TimeDerivative(tau[0])), fd_inv), kBound)
        << "T = " << t[0];
  }
}

TEST(TimeMapTest, VectorHelpersAndChainRule) {
  const VectorXd tau = (VectorXd(4) << -1.5, -0.1, 0.4, 2.2).finished();
  VectorXd t, back;
  DurationsFromTaus(tau, &t);
  ASSERT_TRUE(TausFromDurations(t, &back).ok());
  EXPECT_LT((back - tau).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_FALSE(TausFromDurations((VectorXd(2) << 1.0, 0.0).finished(), &back).ok());
  EXPECT_FALSE(TausFromDurations((VectorXd(2) << 1.0, NAN).finished(), &back).ok());
  EXPECT_FALSE(TausFromDurations(t, nullptr).ok());

  // J(T) = sum_i (i + 1) T_i^2  =>  dJ/dtau by the chain rule.
  auto j_of_tau = [](const VectorXd& x) {
    VectorXd d;
    DurationsFromTaus(x, &d);
    double j = 0.0;
    for (Eigen::Index i = 0; i < d.size(); ++i) j += (i + 1.0) * d[i] * d[i];
    return j;
  };
  VectorXd grad_t(4), grad_tau;
  for (int i = 0; i < 4; ++i) grad_t[i] = 2.0 * (i + 1.0) * t[i];
  DurationGradientToTau(tau, grad_t, &grad_tau);
  EXPECT_LT(RelativeError(grad_tau, NumericGradient(j_of_tau, tau, 1e-3)), kBound);
}

}  // namespace
}  // namespace quadhand::traj

// Finite-difference checks of every MINCO gradient: energy and sampled costs
// with respect to waypoints, durations, head and tail, through the adjoint
// propagation, also chained through the time map.
//
// Error measure (numeric_diff.h): max_i |analytic_i - fd_i| / max_i |fd_i|,
// with 5-point central differences, step 1e-3 * max(1, |x_i|), bound 1e-7;
// the main test also checks 3-point central differences (step 1e-6), bound 1e-6.
#include <algorithm>
#include <cmath>
#include <functional>
#include <random>
#include <tuple>

#include <gtest/gtest.h>

#include "quadhand/traj/minco.h"
#include "quadhand/traj/time_map.h"
#include "traj/numeric_diff.h"

namespace quadhand::traj {
namespace {

using Eigen::MatrixXd;
using Eigen::VectorXd;
using testing::NumericGradient;
using testing::RelativeError;
using testing::Sci;

constexpr double kBound = 1e-7;
constexpr double kStep = 1e-3;
constexpr double kBound3 = 1e-6;

enum class CostKind { kEnergy, kSamples, kBoth };

struct Layout {
  int s, m, n;
  int nq() const { return m * (n - 1); }
  int size() const { return nq() + n + 2 * s * m; }
};

// x = [vec(waypoints), durations, vec(head), vec(tail)] (column-major vec).
void Unpack(const Layout& l, const VectorXd& x, MatrixXd* q, VectorXd* t, MatrixXd* head,
            MatrixXd* tail) {
  int o = 0;
  *q = Eigen::Map<const MatrixXd>(x.data() + o, l.m, l.n - 1);
  o += l.nq();
  *t = x.segment(o, l.n);
  o += l.n;
  *head = Eigen::Map<const MatrixXd>(x.data() + o, l.s, l.m);
  o += l.s * l.m;
  *tail = Eigen::Map<const MatrixXd>(x.data() + o, l.s, l.m);
}

// A non-quadratic sampled cost: phi_d(v) = w_d (||v||^2 + 0.1 (u . v)^3) at
// fractions r of each piece (t = r T_i, moving with T_i) and at the fixed local
// time 0.15 s (not moving with T_i), for derivatives 0 .. min(2s-1, 4).
struct SampledCost {
  static constexpr double kFractions[4] = {0.0, 0.3, 0.77, 1.0};
  static constexpr double kFixedTime = 0.15;

  static double Phi(const VectorXd& v, int d, VectorXd* grad) {
    const double w = 1.0 / (1.0 + d);
    const VectorXd u = VectorXd::LinSpaced(v.size(), 0.5, -0.7);
    const double uv = u.dot(v);
    if (grad != nullptr) *grad = w * (2.0 * v + 0.3 * uv * uv * u);
    return w * (v.squaredNorm() + 0.1 * uv * uv * uv);
  }

  // Value; adds partial gradients (c fixed) when grad_c is not null.
  static double Eval(const Minco& minco, MatrixXd* grad_c, VectorXd* grad_t) {
    const int s = minco.order();
    const int top = std::min(2 * s - 1, 4);
    double value = 0.0;
    VectorXd v(minco.dims()), g(minco.dims());
    for (int i = 0; i < minco.num_pieces(); ++i) {
      const double ti = minco.durations()[i];
      for (int d = 0; d <= top; ++d) {
        for (double r : kFractions) {
          minco.Evaluate(i, r * ti, d, v);
          value += Phi(v, d, grad_c ? &g : nullptr);
          if (grad_c) minco.AddSampleGradient(i, r * ti, d, g, r, *grad_c, *grad_t);
        }
        minco.Evaluate(i, kFixedTime, d, v);
        value += Phi(v, d, grad_c ? &g : nullptr);
        if (grad_c) minco.AddSampleGradient(i, kFixedTime, d, g, 0.0, *grad_c, *grad_t);
      }
    }
    return value;
  }
};

// Cost value; with `grad` non-null also the total gradient w.r.t. x.
double Cost(const Layout& l, CostKind kind, const VectorXd& x, VectorXd* grad) {
  MatrixXd q, head, tail;
  VectorXd t;
  Unpack(l, x, &q, &t, &head, &tail);
  Minco minco;
  EXPECT_TRUE(minco.Reset(l.s, l.m, l.n).ok());
  EXPECT_TRUE(minco.SetBoundary(head, tail).ok());
  const core::Status st = minco.Generate(q, t);
  EXPECT_TRUE(st.ok()) << st.message();

  MatrixXd gc = MatrixXd::Zero(2 * l.s * l.n, l.m);
  VectorXd gt = VectorXd::Zero(l.n);
  double value = 0.0;
  if (kind != CostKind::kSamples) {
    value += minco.Energy();
    if (grad) minco.AddEnergyGradient(gc, gt);
  }
  if (kind != CostKind::kEnergy) {
    value += SampledCost::Eval(minco, grad ? &gc : nullptr, grad ? &gt : nullptr);
  }
  if (grad) {
    MatrixXd gq, gh, gtl;
    VectorXd gT;
    EXPECT_TRUE(minco.PropagateGradient(gc, gt, &gq, &gT, &gh, &gtl).ok());
    grad->resize(l.size());
    int o = 0;
    grad->segment(o, l.nq()) = Eigen::Map<const VectorXd>(gq.data(), l.nq());
    o += l.nq();
    grad->segment(o, l.n) = gT;
    o += l.n;
    grad->segment(o, l.s * l.m) = Eigen::Map<const VectorXd>(gh.data(), l.s * l.m);
    o += l.s * l.m;
    grad->segment(o, l.s * l.m) = Eigen::Map<const VectorXd>(gtl.data(), l.s * l.m);
  }
  return value;
}

VectorXd RandomPoint(const Layout& l, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.5, 1.5);
  std::uniform_real_distribution<double> ut(0.6, 1.8);
  VectorXd x = VectorXd::NullaryExpr(l.size(), [&]() { return u(rng); });
  for (int i = 0; i < l.n; ++i) x[l.nq() + i] = ut(rng);
  return x;
}

// The same measure restricted to one block (scaled by the whole numeric
// gradient), so that a failure names the block.
void ExpectBlock(const VectorXd& analytic, const VectorXd& numeric, int offset, int size,
                 const char* name) {
  if (size == 0) return;
  const double scale = std::max(numeric.cwiseAbs().maxCoeff(), 1e-12);
  const double err =
      (analytic.segment(offset, size) - numeric.segment(offset, size)).cwiseAbs().maxCoeff() /
      scale;
  EXPECT_LT(err, kBound) << name << "\nanalytic " << analytic.segment(offset, size).transpose()
                         << "\nnumeric  " << numeric.segment(offset, size).transpose();
}

class MincoGradientTest
    : public ::testing::TestWithParam<std::tuple<int, int, int, CostKind>> {};

TEST_P(MincoGradientTest, MatchesFiniteDifferences) {
  const auto [s, m, n, kind] = GetParam();
  const Layout l{s, m, n};
  for (unsigned trial = 0; trial < 3; ++trial) {
    const VectorXd x = RandomPoint(l, 1000u * s + 100u * m + 10u * n + trial);
    VectorXd analytic;
    Cost(l, kind, x, &analytic);
    const VectorXd numeric = NumericGradient(
        [&](const VectorXd& y) { return Cost(l, kind, y, nullptr); }, x, kStep);
    const double err = RelativeError(analytic, numeric);
    RecordProperty("rel_error_5pt_trial" + std::to_string(trial), Sci(err));
    EXPECT_LT(err, kBound);
    // Plain 3-point central differences (step 1e-6): bound 1e-6.
    const VectorXd numeric3 = NumericGradient(
        [&](const VectorXd& y) { return Cost(l, kind, y, nullptr); }, x, 1e-6, 3);
    const double err3 = RelativeError(analytic, numeric3);
    RecordProperty("rel_error_3pt_trial" + std::to_string(trial), Sci(err3));
    EXPECT_LT(err3, kBound3);
    ExpectBlock(analytic, numeric, 0, l.nq(), "waypoints");
    ExpectBlock(analytic, numeric, l.nq(), l.n, "durations");
    ExpectBlock(analytic, numeric, l.nq() + l.n, s * m, "head");
    ExpectBlock(analytic, numeric, l.nq() + l.n + s * m, s * m, "tail");
  }
}

std::string Name(const ::testing::TestParamInfo<MincoGradientTest::ParamType>& info) {
  const auto [s, m, n, kind] = info.param;
  const char* k = kind == CostKind::kEnergy ? "Energy" : kind == CostKind::kSamples ? "Samples"
                                                                                     : "Both";
  return std::string(k) + "_s" + std::to_string(s) + "_m" + std::to_string(m) + "_N" +
         std::to_string(n);
}

INSTANTIATE_TEST_SUITE_P(
    All, MincoGradientTest,
    ::testing::Combine(::testing::Values(1, 2, 3, 4), ::testing::Values(1, 3, 4),
                       ::testing::Values(1, 2, 6),
                       ::testing::Values(CostKind::kEnergy, CostKind::kSamples, CostKind::kBoth)),
    Name);

// The partial energy gradient (coefficients held fixed) on its own.
TEST(MincoGradient, EnergyPartialsWithFixedCoefficients) {
  for (int s = 1; s <= 4; ++s) {
    Minco minco;
    ASSERT_TRUE(minco.Reset(s, 2, 3).ok());
    std::mt19937 rng(9u + s);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    MatrixXd head = MatrixXd::NullaryExpr(s, 2, [&]() { return u(rng); });
    MatrixXd tail = MatrixXd::NullaryExpr(s, 2, [&]() { return u(rng); });
    MatrixXd q = MatrixXd::NullaryExpr(2, 2, [&]() { return u(rng); });
    ASSERT_TRUE(minco.SetBoundary(head, tail).ok());
    ASSERT_TRUE(minco.Generate(q, Eigen::Vector3d(0.8, 1.3, 1.1)).ok());
    const MatrixXd c0 = minco.coefficients();
    const VectorXd t0 = minco.durations();
    MatrixXd gc = MatrixXd::Zero(c0.rows(), 2);
    VectorXd gt = VectorXd::Zero(3);
    minco.AddEnergyGradient(gc, gt);

    // Energy of fixed coefficients as a function of (vec(c), T), by quadrature.
    auto energy = [&](const VectorXd& y) {
      const int nc = 2 * s;
      double e = 0.0;
      for (int i = 0; i < 3; ++i) {
        const double ti = y[c0.size() + i];
        for (int j = 0; j < 2; ++j) {
          // integral of (sum_k alpha_k c_k t^(k-s))^2 in closed form
          for (int k = s; k < nc; ++k) {
            for (int l2 = s; l2 < nc; ++l2) {
              double ak = 1.0, al = 1.0;
              for (int r = k - s + 1; r <= k; ++r) ak *= r;
              for (int r = l2 - s + 1; r <= l2; ++r) al *= r;
              const int ex = k + l2 - 2 * s + 1;
              e += ak * al * y[j * c0.rows() + nc * i + k] * y[j * c0.rows() + nc * i + l2] *
                   std::pow(ti, ex) / ex;
            }
          }
        }
      }
      return e;
    };
    VectorXd x(c0.size() + 3);
    x << Eigen::Map<const VectorXd>(c0.data(), c0.size()), t0;
    VectorXd analytic(x.size());
    analytic << Eigen::Map<const VectorXd>(gc.data(), gc.size()), gt;
    EXPECT_NEAR(energy(x), minco.Energy(), 1e-10 * minco.Energy());
    EXPECT_LT(RelativeError(analytic, NumericGradient(energy, x, kStep)), kBound) << "s = " << s;
  }
}

// dK/dtau through the time map, for position (s = 4, m = 3) and yaw + joints
// (s = 2, m = 4) sharing one duration vector: the duration gradients add.
TEST(MincoGradient, SharedDurationsThroughTimeMap) {
  const int n = 5;
  std::mt19937 rng(77);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const MatrixXd h4 = MatrixXd::NullaryExpr(4, 3, [&]() { return u(rng); });
  const MatrixXd t4 = MatrixXd::NullaryExpr(4, 3, [&]() { return u(rng); });
  const MatrixXd q4 = MatrixXd::NullaryExpr(3, n - 1, [&]() { return u(rng); });
  const MatrixXd h2 = MatrixXd::NullaryExpr(2, 4, [&]() { return u(rng); });
  const MatrixXd t2 = MatrixXd::NullaryExpr(2, 4, [&]() { return u(rng); });
  const MatrixXd q2 = MatrixXd::NullaryExpr(4, n - 1, [&]() { return u(rng); });
  const VectorXd tau0 = VectorXd::NullaryExpr(n, [&]() { return 0.8 * u(rng); });

  auto cost = [&](const VectorXd& tau, VectorXd* grad_tau) {
    VectorXd t;
    DurationsFromTaus(tau, &t);
    Minco pos, rest;
    EXPECT_TRUE(pos.Reset(4, 3, n).ok());
    EXPECT_TRUE(rest.Reset(2, 4, n).ok());
    EXPECT_TRUE(pos.SetBoundary(h4, t4).ok());
    EXPECT_TRUE(rest.SetBoundary(h2, t2).ok());
    EXPECT_TRUE(pos.Generate(q4, t).ok());
    EXPECT_TRUE(rest.Generate(q2, t).ok());
    const double rho = 3.0;  // time regularisation rho * sum(T)
    double value = pos.Energy() + rest.Energy() + rho * t.sum();
    MatrixXd gc4 = MatrixXd::Zero(8 * n, 3), gc2 = MatrixXd::Zero(4 * n, 4);
    VectorXd gt4 = VectorXd::Constant(n, rho), gt2 = VectorXd::Zero(n);
    value += SampledCost::Eval(pos, grad_tau ? &gc4 : nullptr, &gt4);
    value += SampledCost::Eval(rest, grad_tau ? &gc2 : nullptr, &gt2);
    if (grad_tau) {
      pos.AddEnergyGradient(gc4, gt4);
      rest.AddEnergyGradient(gc2, gt2);
      MatrixXd gq4, gq2;
      VectorXd total4, total2;
      EXPECT_TRUE(pos.PropagateGradient(gc4, gt4, &gq4, &total4).ok());
      EXPECT_TRUE(rest.PropagateGradient(gc2, gt2, &gq2, &total2).ok());
      DurationGradientToTau(tau, total4 + total2, grad_tau);
    }
    return value;
  };
  VectorXd analytic;
  cost(tau0, &analytic);
  const VectorXd numeric =
      NumericGradient([&](const VectorXd& y) { return cost(y, nullptr); }, tau0, kStep);
  const double err = RelativeError(analytic, numeric);
  RecordProperty("rel_error_5pt", Sci(err));
  EXPECT_LT(err, kBound);
}

}  // namespace
}  // namespace quadhand::traj

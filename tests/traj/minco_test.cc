// MINCO: construction, constraints, closed forms, energy. Gradients are in
// minco_gradient_test.cc.
#include "quadhand/traj/minco.h"

#include <cmath>
#include <random>
#include <string>
#include <tuple>
#include <utility>

#include <gtest/gtest.h>

namespace quadhand::traj {
namespace {

using Eigen::MatrixXd;
using Eigen::VectorXd;

struct Problem {
  MatrixXd head, tail, waypoints;
  VectorXd durations;
};

Problem RandomProblem(int s, int m, int n, unsigned seed, double t_min = 0.5, double t_max = 2.0) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-2.0, 2.0);
  std::uniform_real_distribution<double> ut(t_min, t_max);
  Problem p;
  p.head = MatrixXd::NullaryExpr(s, m, [&]() { return u(rng); });
  p.tail = MatrixXd::NullaryExpr(s, m, [&]() { return u(rng); });
  p.waypoints = MatrixXd::NullaryExpr(m, n - 1, [&]() { return u(rng); });
  p.durations = VectorXd::NullaryExpr(n, [&]() { return ut(rng); });
  return p;
}

void Build(Minco* minco, int s, int m, const Problem& p) {
  ASSERT_TRUE(minco->Reset(s, m, static_cast<int>(p.durations.size())).ok());
  ASSERT_TRUE(minco->SetBoundary(p.head, p.tail).ok());
  const core::Status st = minco->Generate(p.waypoints, p.durations);
  ASSERT_TRUE(st.ok()) << st.message();
}

// Relative agreement |a - b| <= tol * max(1, |b|), element-wise.
void ExpectClose(const VectorXd& a, const VectorXd& b, double tol, const std::string& what) {
  ASSERT_EQ(a.size(), b.size());
  for (Eigen::Index i = 0; i < a.size(); ++i) {
    EXPECT_NEAR(a[i], b[i], tol * std::max(1.0, std::abs(b[i]))) << what << " entry " << i;
  }
}

TEST(MincoTest, ResetRejectsBadSizes) {
  Minco minco;
  EXPECT_EQ(minco.Reset(0, 3, 2).code(), core::StatusCode::kInvalidArgument);
  EXPECT_EQ(minco.Reset(5, 3, 2).code(), core::StatusCode::kInvalidArgument);
  EXPECT_EQ(minco.Reset(3, 0, 2).code(), core::StatusCode::kInvalidArgument);
  EXPECT_EQ(minco.Reset(3, 3, 0).code(), core::StatusCode::kInvalidArgument);
  EXPECT_TRUE(minco.Reset(3, 3, 2).ok());
  EXPECT_EQ(minco.order(), 3);
  EXPECT_EQ(minco.dims(), 3);
  EXPECT_EQ(minco.num_pieces(), 2);
  EXPECT_EQ(minco.coefficients().rows(), 12);
}

TEST(MincoTest, MethodsBeforeResetFail) {
  Minco minco;
  EXPECT_FALSE(minco.SetBoundary(MatrixXd::Zero(2, 1), MatrixXd::Zero(2, 1)).ok());
  EXPECT_FALSE(minco.Generate(MatrixXd::Zero(1, 0), VectorXd::Ones(1)).ok());
  EXPECT_FALSE(minco.valid());
}

TEST(MincoTest, GenerateRejectsBadInput) {
  Minco minco;
  ASSERT_TRUE(minco.Reset(2, 3, 3).ok());
  EXPECT_FALSE(minco.SetBoundary(MatrixXd::Zero(3, 3), MatrixXd::Zero(2, 3)).ok());
  MatrixXd bad_head = MatrixXd::Zero(2, 3);
  bad_head(0, 0) = std::nan("");
  EXPECT_FALSE(minco.SetBoundary(bad_head, MatrixXd::Zero(2, 3)).ok());
  ASSERT_TRUE(minco.SetBoundary(MatrixXd::Zero(2, 3), MatrixXd::Ones(2, 3)).ok());

  const MatrixXd q = MatrixXd::Ones(3, 2);
  EXPECT_EQ(minco.Generate(MatrixXd::Ones(3, 3), VectorXd::Ones(3)).code(),
            core::StatusCode::kInvalidArgument);
  EXPECT_EQ(minco.Generate(q, VectorXd::Ones(2)).code(), core::StatusCode::kInvalidArgument);
  EXPECT_EQ(minco.Generate(q, Eigen::Vector3d(1.0, 0.0, 1.0)).code(),
            core::StatusCode::kInvalidArgument);
  EXPECT_EQ(minco.Generate(q, Eigen::Vector3d(1.0, -1.0, 1.0)).code(),
            core::StatusCode::kInvalidArgument);
  EXPECT_EQ(minco.Generate(q, Eigen::Vector3d(1.0, INFINITY, 1.0)).code(),
            core::StatusCode::kInvalidArgument);
  MatrixXd q_nan = q;
  q_nan(1, 1) = std::nan("");
  EXPECT_EQ(minco.Generate(q_nan, VectorXd::Ones(3)).code(), core::StatusCode::kInvalidArgument);
  EXPECT_FALSE(minco.valid());

  // Propagation needs a valid trajectory.
  MatrixXd gq;
  VectorXd gt;
  EXPECT_FALSE(minco.PropagateGradient(MatrixXd::Zero(12, 3), VectorXd::Zero(3), &gq, &gt).ok());
  ASSERT_TRUE(minco.Generate(q, VectorXd::Ones(3)).ok());
  EXPECT_TRUE(minco.valid());
  EXPECT_FALSE(minco.PropagateGradient(MatrixXd::Zero(11, 3), VectorXd::Zero(3), &gq, &gt).ok());
  EXPECT_FALSE(minco.PropagateGradient(MatrixXd::Zero(12, 3), VectorXd::Zero(3), nullptr, &gt).ok());
  EXPECT_TRUE(minco.PropagateGradient(MatrixXd::Zero(12, 3), VectorXd::Zero(3), &gq, &gt).ok());
}

// s = 3, one piece, rest to rest: x(t) = x0 + (x1 - x0)(10 r^3 - 15 r^4 + 6 r^5), r = t / T.
TEST(MincoTest, MinimumJerkRestToRestMatchesClosedForm) {
  const double T = 1.7;
  const Eigen::Vector2d x0(0.3, -1.0), x1(2.5, 4.0);
  MatrixXd head = MatrixXd::Zero(3, 2), tail = MatrixXd::Zero(3, 2);
  head.row(0) = x0.transpose();
  tail.row(0) = x1.transpose();
  Minco minco;
  ASSERT_TRUE(minco.Reset(3, 2, 1).ok());
  ASSERT_TRUE(minco.SetBoundary(head, tail).ok());
  ASSERT_TRUE(minco.Generate(MatrixXd(2, 0), VectorXd::Constant(1, T)).ok());

  // Coefficients: c3 = 10 D / T^3, c4 = -15 D / T^4, c5 = 6 D / T^5.
  const MatrixXd& c = minco.coefficients();
  for (int j = 0; j < 2; ++j) {
    const double d = x1[j] - x0[j];
    EXPECT_NEAR(c(0, j), x0[j], 1e-12);
    EXPECT_NEAR(c(1, j), 0.0, 1e-12);
    EXPECT_NEAR(c(2, j), 0.0, 1e-12);
    EXPECT_NEAR(c(3, j), 10.0 * d / std::pow(T, 3), 1e-11);
    EXPECT_NEAR(c(4, j), -15.0 * d / std::pow(T, 4), 1e-11);
    EXPECT_NEAR(c(5, j), 6.0 * d / std::pow(T, 5), 1e-11);
  }
  for (double r = 0.0; r <= 1.0; r += 0.05) {
    const VectorXd x = minco.Evaluate(0, r * T, 0);
    const double shape = 10 * r * r * r - 15 * r * r * r * r + 6 * r * r * r * r * r;
    const double dshape = (30 * r * r - 60 * r * r * r + 30 * r * r * r * r) / T;
    for (int j = 0; j < 2; ++j) {
      EXPECT_NEAR(x[j], x0[j] + (x1[j] - x0[j]) * shape, 1e-12);
      EXPECT_NEAR(minco.Evaluate(0, r * T, 1)[j], (x1[j] - x0[j]) * dshape, 1e-11);
    }
  }
  // Energy of the minimum-jerk trajectory: 720 D^2 / T^5 per column.
  const double expected = 720.0 * (x1 - x0).squaredNorm() / std::pow(T, 5);
  EXPECT_NEAR(minco.Energy(), expected, 1e-10 * expected);
}

// Head, tail, waypoints and C^{2s-2} continuity, for every order and column count.
class MincoConstraintTest : public ::testing::TestWithParam<std::tuple<int, int, int>> {};

TEST_P(MincoConstraintTest, BoundaryWaypointsAndContinuityHold) {
  const auto [s, m, n] = GetParam();
  const Problem p = RandomProblem(s, m, n, 100u * s + 10u * m + n);
  Minco minco;
  Build(&minco, s, m, p);
  const double tol = 1e-9;

  for (int k = 0; k < s; ++k) {
    ExpectClose(minco.Evaluate(0, 0.0, k), p.head.row(k).transpose(), tol, "head");
    ExpectClose(minco.Evaluate(n - 1, p.durations[n - 1], k), p.tail.row(k).transpose(), tol,
                "tail");
  }
  double max_jump_top = 0.0;
  for (int i = 0; i + 1 < n; ++i) {
    ExpectClose(minco.Evaluate(i, p.durations[i], 0), p.waypoints.col(i), tol, "waypoint");
    for (int d = 0; d <= 2 * s - 2; ++d) {
      ExpectClose(minco.Evaluate(i, p.durations[i], d), minco.Evaluate(i + 1, 0.0, d), tol,
                  "continuity of derivative " + std::to_string(d));
    }
    const VectorXd jump =
        minco.Evaluate(i, p.durations[i], 2 * s - 1) - minco.Evaluate(i + 1, 0.0, 2 * s - 1);
    max_jump_top = std::max(max_jump_top, jump.cwiseAbs().maxCoeff());
  }
  // C^{2s-2} is all MINCO guarantees: derivative 2s-1 jumps for generic data.
  if (n > 1) {
    EXPECT_GT(max_jump_top, 1e-3);
  }
  // Derivatives beyond the degree are zero.
  EXPECT_EQ(minco.Evaluate(0, 0.3, 2 * s).cwiseAbs().maxCoeff(), 0.0);
}

INSTANTIATE_TEST_SUITE_P(OrdersAndDims, MincoConstraintTest,
                         ::testing::Combine(::testing::Values(1, 2, 3, 4),
                                            ::testing::Values(1, 3, 4),
                                            ::testing::Values(1, 2, 7)));

// Many pieces, at small and large time scales and with adjacent durations
// differing up to 40x: the unpivoted banded LU stays accurate.
TEST(MincoTest, ManyPiecesStayAccurate) {
  const std::pair<double, double> ranges[] = {{0.1, 4.0}, {0.01, 0.03}, {30.0, 100.0}};
  for (int s = 2; s <= 4; ++s) {
    for (const auto& [t_min, t_max] : ranges) {
      SCOPED_TRACE("s = " + std::to_string(s) + ", T in [" + std::to_string(t_min) + ", " +
                   std::to_string(t_max) + "]");
      const int n = 400;
      const Problem p = RandomProblem(s, 3, n, 7u + s, t_min, t_max);
      Minco minco;
      Build(&minco, s, 3, p);
      for (int i = 0; i + 1 < n; ++i) {
        ExpectClose(minco.Evaluate(i, p.durations[i], 0), p.waypoints.col(i), 1e-8, "waypoint");
        for (int d = 1; d <= 2 * s - 2; ++d) {
          ExpectClose(minco.Evaluate(i, p.durations[i], d), minco.Evaluate(i + 1, 0.0, d), 1e-7,
                      "continuity");
        }
      }
      for (int k = 0; k < s; ++k) {
        ExpectClose(minco.Evaluate(n - 1, p.durations[n - 1], k), p.tail.row(k).transpose(),
                    1e-8, "tail");
      }
    }
  }
}

// Waypoints taken from the one-piece optimum reproduce it (uniqueness of MINCO).
TEST(MincoTest, SplittingTheOptimumReproducesIt) {
  for (int s = 1; s <= 4; ++s) {
    const Problem one = RandomProblem(s, 2, 1, 42u + s, 2.0, 3.0);
    Minco whole;
    Build(&whole, s, 2, one);
    const double total = one.durations[0];
    const VectorXd fractions = (VectorXd(3) << 0.2, 0.35, 0.25).finished();
    Problem split = one;
    split.durations = fractions * total;
    split.durations.conservativeResize(4);
    split.durations[3] = total - fractions.sum() * total;
    split.waypoints.resize(2, 3);
    double t = 0.0;
    for (int i = 0; i < 3; ++i) {
      t += split.durations[i];
      split.waypoints.col(i) = whole.Evaluate(0, t, 0);
    }
    Minco pieces;
    Build(&pieces, s, 2, split);
    for (double g = 0.0; g <= total; g += total / 37.0) {
      int piece = 0;
      double local = 0.0;
      pieces.LocatePiece(g, &piece, &local);
      for (int d = 0; d < 2 * s; ++d) {
        ExpectClose(pieces.Evaluate(piece, local, d), whole.Evaluate(0, g, d), 1e-8, "split");
      }
    }
    EXPECT_NEAR(pieces.Energy(), whole.Energy(), 1e-9 * std::max(1.0, whole.Energy()));
  }
}

// s = 2 (minimum acceleration, cubic pieces) passes through its waypoints and is C^2.
TEST(MincoTest, MinimumAccelerationPassesThroughWaypoints) {
  const Problem p = RandomProblem(2, 4, 6, 5u);
  Minco minco;
  Build(&minco, 2, 4, p);
  for (int i = 0; i < 5; ++i) {
    ExpectClose(minco.Evaluate(i, p.durations[i], 0), p.waypoints.col(i), 1e-12, "waypoint");
    ExpectClose(minco.Evaluate(i + 1, 0.0, 0), p.waypoints.col(i), 1e-12, "waypoint");
  }
}

// Energy against Gauss-Legendre quadrature (exact for these degrees).
TEST(MincoTest, EnergyMatchesQuadrature) {
  const double nodes[5] = {-0.9061798459386640, -0.5384693101056831, 0.0, 0.5384693101056831,
                           0.9061798459386640};
  const double weights[5] = {0.2369268850561891, 0.4786286704993665, 0.5688888888888889,
                             0.4786286704993665, 0.2369268850561891};
  for (int s = 1; s <= 4; ++s) {
    const Problem p = RandomProblem(s, 3, 5, 11u + s);
    Minco minco;
    Build(&minco, s, 3, p);
    double quad = 0.0;
    for (int i = 0; i < 5; ++i) {
      const double half = 0.5 * p.durations[i];
      for (int k = 0; k < 5; ++k) {
        quad += half * weights[k] * minco.Evaluate(i, half * (1.0 + nodes[k]), s).squaredNorm();
      }
    }
    EXPECT_NEAR(minco.Energy(), quad, 1e-11 * quad) << "s = " << s;
  }
}

TEST(MincoTest, LocatePieceClampsAndSplits) {
  const Problem p = RandomProblem(3, 1, 3, 3u);
  Minco minco;
  Build(&minco, 3, 1, p);
  int piece = -1;
  double t = -1.0;
  minco.LocatePiece(-5.0, &piece, &t);
  EXPECT_EQ(piece, 0);
  EXPECT_EQ(t, 0.0);
  minco.LocatePiece(p.durations[0] + 0.25 * p.durations[1], &piece, &t);
  EXPECT_EQ(piece, 1);
  EXPECT_NEAR(t, 0.25 * p.durations[1], 1e-12);
  minco.LocatePiece(1e9, &piece, &t);
  EXPECT_EQ(piece, 2);
  EXPECT_EQ(t, p.durations[2]);
  EXPECT_NEAR(minco.total_duration(), p.durations.sum(), 1e-15);
}

// A replan that rejoins a plan (planner/replan.h) joins its new pieces to
// the plan's last ones: every derivative of every piece is the part's own,
// the head is the first part's and the tail the second's.
TEST(MincoTest, JoinedKeepsEachPartsPiecesAndTimes) {
  const Problem a = RandomProblem(4, 3, 3, 11u), b = RandomProblem(4, 3, 5, 12u);
  Minco first, second;
  Build(&first, 4, 3, a);
  Build(&second, 4, 3, b);
  auto joined = Minco::Joined(first, second, 2);
  ASSERT_TRUE(joined.ok()) << joined.status().message();
  ASSERT_EQ(joined->num_pieces(), 3 + 3);
  EXPECT_NEAR(joined->total_duration(), a.durations.sum() + b.durations.tail(3).sum(), 1e-12);
  EXPECT_EQ(joined->head(), first.head());
  EXPECT_EQ(joined->tail(), second.tail());
  for (int piece = 0; piece < joined->num_pieces(); ++piece) {
    const Minco& source = piece < 3 ? first : second;
    const int source_piece = piece < 3 ? piece : piece - 3 + 2;
    for (double f : {0.0, 0.3, 1.0}) {
      const double t = f * joined->durations()[piece];
      for (int d = 0; d < 8; ++d) {
        EXPECT_EQ(joined->Evaluate(piece, t, d), source.Evaluate(source_piece, t, d)) << piece << " " << d;
      }
    }
  }
  int piece = -1;
  double local = 0.0;
  joined->LocatePiece(a.durations.sum() + b.durations[2] + 0.5 * b.durations[3], &piece, &local);
  EXPECT_EQ(piece, 4);
  EXPECT_NEAR(local, 0.5 * b.durations[3], 1e-12);
}

// A long plan solved in overlapping sections keeps each section's first
// pieces (planner.h, section_pieces): the prefix has every derivative of
// those pieces, the head, and as tail the state where they end.
TEST(MincoTest, APrefixKeepsTheFirstPiecesAndEndsWhereTheyEnd) {
  const Problem a = RandomProblem(4, 3, 5, 16u);
  Minco whole;
  Build(&whole, 4, 3, a);
  auto prefix = Minco::Prefix(whole, 3);
  ASSERT_TRUE(prefix.ok()) << prefix.status().message();
  ASSERT_EQ(prefix->num_pieces(), 3);
  EXPECT_NEAR(prefix->total_duration(), a.durations.head(3).sum(), 1e-15);
  EXPECT_EQ(prefix->head(), whole.head());
  for (int piece = 0; piece < 3; ++piece) {
    for (double f : {0.0, 0.6, 1.0}) {
      for (int d = 0; d < 8; ++d) {
        const double t = f * a.durations[piece];
        EXPECT_EQ(prefix->Evaluate(piece, t, d), whole.Evaluate(piece, t, d));
      }
    }
  }
  for (int d = 0; d < 4; ++d) {
    EXPECT_TRUE(prefix->tail().row(d).transpose().isApprox(whole.Evaluate(3, 0.0, d), 1e-9) ||
                (prefix->tail().row(d).transpose() - whole.Evaluate(3, 0.0, d)).norm() < 1e-9)
        << d;
  }
  EXPECT_TRUE(Minco::Prefix(whole, 5).ok());
  EXPECT_FALSE(Minco::Prefix(whole, 0).ok());
  EXPECT_FALSE(Minco::Prefix(whole, 6).ok());
  EXPECT_FALSE(Minco::Prefix(Minco(), 1).ok());
}

TEST(MincoTest, JoinedRefusesMismatchedParts) {
  const Problem a = RandomProblem(4, 3, 3, 13u), b = RandomProblem(2, 3, 3, 14u), c = RandomProblem(4, 2, 3, 15u);
  Minco first, other_order, other_dims, unset;
  Build(&first, 4, 3, a);
  Build(&other_order, 2, 3, b);
  Build(&other_dims, 4, 2, c);
  EXPECT_FALSE(Minco::Joined(first, other_order, 0).ok());
  EXPECT_FALSE(Minco::Joined(first, other_dims, 0).ok());
  EXPECT_FALSE(Minco::Joined(first, unset, 0).ok());
  EXPECT_FALSE(Minco::Joined(first, first, 3).ok());
  EXPECT_FALSE(Minco::Joined(first, first, -1).ok());
  EXPECT_TRUE(Minco::Joined(first, first, 2).ok());
}

TEST(MincoTest, ResetWithSameSizesKeepsBuffers) {
  Minco minco;
  ASSERT_TRUE(minco.Reset(4, 3, 10).ok());
  const double* before = minco.coefficients().data();
  ASSERT_TRUE(minco.Reset(4, 3, 10).ok());
  EXPECT_EQ(minco.coefficients().data(), before);
  ASSERT_TRUE(minco.Reset(4, 3, 11).ok());
  EXPECT_EQ(minco.coefficients().rows(), 88);
}

}  // namespace
}  // namespace quadhand::traj

// MINCO cost per evaluation: solve (build + banded LU + solve) and solve plus
// energy gradient plus adjoint propagation, for the planner's two
// trajectories: position (s = 4, m = 3) and yaw + joints (s = 2, m = 4).
// The complexity fit over N = 10, 50, 200 shows the O(N) scaling.
#include <random>

#include <benchmark/benchmark.h>

#include "quadhand/traj/minco.h"

namespace {

using Eigen::MatrixXd;
using Eigen::VectorXd;
using quadhand::traj::Minco;

struct Fixture {
  Fixture(int s, int m, int n) {
    std::mt19937 rng(1);
    std::uniform_real_distribution<double> u(-3.0, 3.0), ut(0.3, 1.5);
    minco.Reset(s, m, n);
    minco.SetBoundary(MatrixXd::NullaryExpr(s, m, [&]() { return u(rng); }),
                      MatrixXd::NullaryExpr(s, m, [&]() { return u(rng); }));
    waypoints = MatrixXd::NullaryExpr(m, n - 1, [&]() { return u(rng); });
    durations = VectorXd::NullaryExpr(n, [&]() { return ut(rng); });
    grad_c.setZero(2 * s * n, m);
    grad_t.setZero(n);
    grad_q.setZero(m, n - 1);
    total_t.setZero(n);
  }
  Minco minco;
  MatrixXd waypoints, grad_c, grad_q;
  VectorXd durations, grad_t, total_t;
};

void BM_Solve(benchmark::State& state, int s, int m) {
  const int n = static_cast<int>(state.range(0));
  Fixture f(s, m, n);
  for (auto _ : state) {
    if (!f.minco.Generate(f.waypoints, f.durations).ok()) state.SkipWithError("generate failed");
    benchmark::DoNotOptimize(f.minco.coefficients().data());
  }
  state.SetComplexityN(n);
  state.counters["pieces/s"] = benchmark::Counter(static_cast<double>(n) * state.iterations(),
                                                  benchmark::Counter::kIsRate);
}

void BM_SolveAndPropagate(benchmark::State& state, int s, int m) {
  const int n = static_cast<int>(state.range(0));
  Fixture f(s, m, n);
  for (auto _ : state) {
    if (!f.minco.Generate(f.waypoints, f.durations).ok()) state.SkipWithError("generate failed");
    f.grad_c.setZero();
    f.grad_t.setZero();
    f.minco.AddEnergyGradient(f.grad_c, f.grad_t);
    if (!f.minco.PropagateGradient(f.grad_c, f.grad_t, &f.grad_q, &f.total_t).ok()) {
      state.SkipWithError("propagation failed");
    }
    benchmark::DoNotOptimize(f.grad_q.data());
    benchmark::DoNotOptimize(f.total_t.data());
  }
  state.SetComplexityN(n);
  state.counters["pieces/s"] = benchmark::Counter(static_cast<double>(n) * state.iterations(),
                                                  benchmark::Counter::kIsRate);
}

BENCHMARK_CAPTURE(BM_Solve, s4_m3, 4, 3)->Arg(10)->Arg(50)->Arg(200)->Complexity(benchmark::oN);
BENCHMARK_CAPTURE(BM_Solve, s2_m4, 2, 4)->Arg(10)->Arg(50)->Arg(200)->Complexity(benchmark::oN);
BENCHMARK_CAPTURE(BM_SolveAndPropagate, s4_m3, 4, 3)
    ->Arg(10)->Arg(50)->Arg(200)->Complexity(benchmark::oN);
BENCHMARK_CAPTURE(BM_SolveAndPropagate, s2_m4, 2, 4)
    ->Arg(10)->Arg(50)->Arg(200)->Complexity(benchmark::oN);

}  // namespace

BENCHMARK_MAIN();

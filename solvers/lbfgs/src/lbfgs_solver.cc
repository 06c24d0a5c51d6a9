#include "quadhand/solvers/lbfgs_solver.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <vector>

#include "quadhand/core/log.h"
#include "quadhand/core/text.h"
#include "quadhand/opt/solver_registry.h"

namespace quadhand::solvers {
namespace {

using opt::SolveStatus;

constexpr double kCautiousEpsilon = 1e-6;
constexpr double kInfinity = std::numeric_limits<double>::infinity();

// The newest `size` of up to `capacity` correction pairs (s, y), in a ring.
class PairMemory {
 public:
  PairMemory(int n, int capacity) : s_(n, capacity), y_(n, capacity), rho_(capacity) {}

  void Clear() { size_ = 0; }
  int size() const { return size_; }

  void Push(const VecX& s, const VecX& y, double sy) {
    s_.col(next_) = s;
    y_.col(next_) = y;
    rho_[next_] = 1.0 / sy;
    next_ = (next_ + 1) % capacity();
    size_ = std::min(size_ + 1, capacity());
  }

  // d = -H g by the two-loop recursion.
  VecX Direction(const VecX& g) {
    VecX q = g;
    alpha_.resize(capacity());
    for (int k = size_ - 1; k >= 0; --k) {
      const int i = Index(k);
      alpha_[i] = rho_[i] * s_.col(i).dot(q);
      q -= alpha_[i] * y_.col(i);
    }
    const int newest = Index(size_ - 1);
    q *= 1.0 / (rho_[newest] * y_.col(newest).squaredNorm());  // s'y / y'y
    for (int k = 0; k < size_; ++k) {
      const int i = Index(k);
      const double beta = rho_[i] * y_.col(i).dot(q);
      q += (alpha_[i] - beta) * s_.col(i);
    }
    return -q;
  }

 private:
  int capacity() const { return static_cast<int>(s_.cols()); }
  // Column of the k-th oldest stored pair.
  int Index(int k) const { return (next_ - size_ + k + capacity()) % capacity(); }

  MatX s_;
  MatX y_;
  VecX rho_;
  VecX alpha_;
  int next_ = 0;
  int size_ = 0;
};

// A point with its cost and gradient.
struct Point {
  VecX x;
  double f = 0.0;
  VecX g;
};

enum class SearchOutcome { kWolfe, kArmijoOnly, kNoDecrease, kAllEvaluationsFailed, kTimeout };

struct SearchResult {
  SearchOutcome outcome = SearchOutcome::kNoDecrease;
  Point point;  // valid for kWolfe and kArmijoOnly
  double step = 0.0;
  int trials = 0;
};

class Run {
 public:
  Run(const opt::Objective& objective, const opt::SolverOptions& options)
      : objective_(objective), options_(options), start_(std::chrono::steady_clock::now()) {}

  double Elapsed() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  }
  bool TimeUp() const { return Elapsed() >= options_.max_time_seconds; }

  bool Evaluate(const VecX& x, double* f, VecX* g) const {
    return objective_.Evaluate(x, f, g) && std::isfinite(*f) && g->allFinite();
  }

  // Lewis-Overton weak Wolfe search along d from `from`, with g'd = gd < 0.
  SearchResult Search(const Point& from, const VecX& d, double gd, double t0) const {
    const double c1 = options_.line_search_c1;
    const double c2 = options_.line_search_c2;
    const double d_max = d.lpNorm<Eigen::Infinity>();
    const double x_scale = std::max(1.0, from.x.lpNorm<Eigen::Infinity>());
    SearchResult result;
    double lo = 0.0;
    double hi = kInfinity;
    double t = t0;
    int failed = 0;
    Point trial;
    for (int k = 0; k < options_.line_search_max_steps; ++k) {
      if (k > 0 && TimeUp()) {
        result.outcome = SearchOutcome::kTimeout;
        break;
      }
      // Steps below rounding of x cannot change the point any more.
      if (t * d_max <= 1e-16 * x_scale) break;
      ++result.trials;
      trial.x = from.x + t * d;
      if (!Evaluate(trial.x, &trial.f, &trial.g)) {
        ++failed;
        hi = t;
      } else if (trial.f > from.f + c1 * t * gd) {
        hi = t;
      } else if (trial.g.dot(d) < c2 * gd) {
        lo = t;
        result.point = trial;
        result.step = t;
        result.outcome = SearchOutcome::kArmijoOnly;
      } else {
        result.point = std::move(trial);
        result.step = t;
        result.outcome = SearchOutcome::kWolfe;
        return result;
      }
      t = hi < kInfinity ? 0.5 * (lo + hi) : 2.0 * lo;
    }
    if (result.outcome == SearchOutcome::kNoDecrease && result.trials > 0 &&
        failed == result.trials) {
      result.outcome = SearchOutcome::kAllEvaluationsFailed;
    }
    return result;
  }

 private:
  const opt::Objective& objective_;
  const opt::SolverOptions& options_;
  std::chrono::steady_clock::time_point start_;
};

using core::Format;

}  // namespace

void LbfgsSolver::DoSolve(const opt::Objective& objective, const VecX& x0,
                          const opt::SolverOptions& options, opt::SolveResult* result) const {
  Run run(objective, options);
  Point current;
  current.x = x0;
  if (!run.Evaluate(current.x, &current.f, &current.g)) {
    result->status = SolveStatus::kEvaluationFailed;
    result->message = "the objective could not be evaluated (or was not finite) at x0";
    return;
  }

  const auto finish = [&](SolveStatus status, std::string message, int iterations) {
    result->status = status;
    result->message = std::move(message);
    result->iterations = iterations;
    result->x = current.x;
    result->cost = current.f;
    result->gradient_max_norm = current.g.lpNorm<Eigen::Infinity>();
  };

  PairMemory memory(static_cast<int>(x0.size()), options.memory_size);
  std::vector<double> costs{current.f};  // cost after each accepted step
  int iteration = 0;
  int skipped_pairs = 0;
  while (true) {
    const double g_max = current.g.lpNorm<Eigen::Infinity>();
    if (g_max <= options.gradient_tolerance) {
      return finish(SolveStatus::kConverged,
                    Format("gradient max-norm %.3g <= tolerance %.3g", g_max,
                           options.gradient_tolerance),
                    iteration);
    }
    if (iteration >= options.max_iterations) {
      return finish(SolveStatus::kMaxIterations,
                    "reached max_iterations = " + std::to_string(options.max_iterations),
                    iteration);
    }
    if (run.TimeUp()) {
      return finish(SolveStatus::kTimeout,
                    Format("wall time %.3g s >= max_time_seconds %.3g", run.Elapsed(),
                           options.max_time_seconds),
                    iteration);
    }

    VecX d;
    double gd = 0.0;
    if (memory.size() > 0) {
      d = memory.Direction(current.g);
      gd = current.g.dot(d);
      if (!(gd < 0.0) || !d.allFinite()) memory.Clear();  // not a descent direction
    }
    const bool steepest = memory.size() == 0;
    if (steepest) {
      d = -current.g;
      gd = -current.g.squaredNorm();
    }
    const double t0 = steepest ? std::min(1.0, 1.0 / d.norm()) : 1.0;

    SearchResult search = run.Search(current, d, gd, t0);
    switch (search.outcome) {
      case SearchOutcome::kWolfe:
      case SearchOutcome::kArmijoOnly:
        break;
      case SearchOutcome::kTimeout:
        return finish(SolveStatus::kTimeout,
                      Format("wall time %.3g s >= max_time_seconds %.3g (in a line search)",
                             run.Elapsed(), options.max_time_seconds),
                      iteration);
      case SearchOutcome::kNoDecrease:
      case SearchOutcome::kAllEvaluationsFailed:
        if (!steepest) {
          memory.Clear();  // retry this iteration along -g
          continue;
        }
        if (search.outcome == SearchOutcome::kAllEvaluationsFailed) {
          return finish(SolveStatus::kEvaluationFailed,
                        "every trial point of the line search failed to evaluate (" +
                            std::to_string(search.trials) + " trials)",
                        iteration);
        }
        return finish(SolveStatus::kLineSearchFailed,
                      "no step along steepest descent decreases the cost enough after " +
                          std::to_string(search.trials) +
                          " trials (at a kink or at the limit of rounding)",
                      iteration);
    }

    const VecX s = search.point.x - current.x;
    const VecX y = search.point.g - current.g;
    const double sy = s.dot(y);
    if (sy > kCautiousEpsilon * s.squaredNorm() * current.g.norm()) {
      memory.Push(s, y, sy);
    } else {
      ++skipped_pairs;
    }
    current = std::move(search.point);
    ++iteration;
    costs.push_back(current.f);
    if (options.verbosity >= 2) {
      core::LogInfo("lbfgs %5d  cost %.12g  |g|inf %.3e  step %.3e  trials %d%s", iteration,
                    current.f, current.g.lpNorm<Eigen::Infinity>(), search.step, search.trials,
                    search.outcome == SearchOutcome::kArmijoOnly ? "  (armijo only)" : "");
    }

    const int window = options.relative_cost_window;
    if (options.relative_cost_tolerance > 0.0 && iteration >= window) {
      const double before = costs[iteration - window];
      const double relative = std::abs(before - current.f) / std::max(1.0, std::abs(current.f));
      if (relative < options.relative_cost_tolerance) {
        std::string message = Format("relative cost decrease %.3g < tolerance %.3g", relative,
                                     options.relative_cost_tolerance) +
                              " over " + std::to_string(window) + " iterations";
        if (skipped_pairs > 0)
          message += "; " + std::to_string(skipped_pairs) + " curvature pairs skipped";
        return finish(SolveStatus::kConverged, std::move(message), iteration);
      }
    }
  }
}

core::Status RegisterLbfgsSolver() {
  static const core::Status status = opt::RegisterSolver(
      "lbfgs", [](const std::string& argument) -> core::Result<std::unique_ptr<opt::Solver>> {
        if (!argument.empty())
          return core::Status::InvalidArgument("lbfgs takes no argument, got '" + argument + "'");
        return std::unique_ptr<opt::Solver>(std::make_unique<LbfgsSolver>());
      });
  return status;
}

}  // namespace quadhand::solvers

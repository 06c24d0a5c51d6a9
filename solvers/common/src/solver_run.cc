#include "quadhand/solvers/solver_run.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <utility>

#include "quadhand/core/log.h"
#include "quadhand/core/text.h"

namespace quadhand::solvers {
namespace {

constexpr int kCacheSize = 4;

using core::Format;

}  // namespace

SolverRun::SolverRun(const opt::Objective& objective, const opt::SolverOptions& options,
                     std::string label)
    : objective_(objective),
      options_(options),
      label_(std::move(label)),
      n_(objective.num_variables()),
      start_(std::chrono::steady_clock::now()),
      cache_(kCacheSize) {}

double SolverRun::Elapsed() const {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
}

double SolverRun::RemainingSeconds() const {
  return std::max(0.0, options_.max_time_seconds - Elapsed());
}

bool SolverRun::TimeUp() const { return Elapsed() >= options_.max_time_seconds; }

bool SolverRun::SameX(const VecX& a, const double* b) const {
  return a.size() == n_ && std::equal(a.data(), a.data() + n_, b);
}

const SolverRun::CachedPoint* SolverRun::Find(const double* x, bool need_grad) const {
  for (const CachedPoint& point : cache_) {
    if (!SameX(point.x, x)) continue;
    if (!point.ok || !need_grad || point.has_grad) return &point;
  }
  return nullptr;
}

bool SolverRun::Evaluate(const double* x, double* cost, double* grad) {
  if (const CachedPoint* hit = Find(x, grad != nullptr)) {
    if (!hit->ok) return false;
    *cost = hit->cost;
    if (grad != nullptr) std::copy(hit->grad.data(), hit->grad.data() + n_, grad);
    return true;
  }
  CachedPoint& point = cache_[cache_next_];
  cache_next_ = (cache_next_ + 1) % kCacheSize;
  point.x = Eigen::Map<const VecX>(x, n_);
  point.has_grad = grad != nullptr;
  point.ok = objective_.Evaluate(point.x, &point.cost, point.has_grad ? &point.grad : nullptr) &&
             std::isfinite(point.cost) && (!point.has_grad || point.grad.allFinite());
  if (!point.ok) {
    ++failures_since_iterate_;
    return false;
  }
  ++successes_since_iterate_;
  *cost = point.cost;
  if (grad != nullptr) std::copy(point.grad.data(), point.grad.data() + n_, grad);
  return true;
}

const double* SolverRun::RecentPointWithCost(double cost) const {
  for (int k = 1; k <= kCacheSize; ++k) {
    const CachedPoint& point = cache_[(cache_next_ - k + kCacheSize) % kCacheSize];
    if (point.ok && point.x.size() == n_ && point.cost == cost) return point.x.data();
  }
  return nullptr;
}

SolverRun::Stop SolverRun::AcceptIterate(const double* x, double cost, double gradient_max_norm) {
  if (stop_ != Stop::kNone) return stop_;
  if (x != nullptr) {
    if (const CachedPoint* hit = Find(x, /*need_grad=*/true); hit != nullptr && hit->ok)
      gradient_max_norm = hit->grad.lpNorm<Eigen::Infinity>();
  }
  if (has_iterate_) ++iterations_;
  has_iterate_ = true;
  if (x != nullptr) {
    x_ = Eigen::Map<const VecX>(x, n_);
    x_known_ = true;
  }
  cost_ = cost;
  gradient_max_norm_ = gradient_max_norm;
  costs_.push_back(cost);
  successes_since_iterate_ = 0;
  failures_since_iterate_ = 0;
  if (options_.verbosity >= 2) {
    core::LogInfo("%s %5d  cost %.12g  |g|inf %.3e", label_.c_str(), iterations_, cost,
                  gradient_max_norm);
  }

  if (GradientTest(gradient_max_norm)) return stop_;
  const int window = options_.relative_cost_window;
  if (options_.relative_cost_tolerance > 0.0 && iterations_ >= window) {
    const double before = costs_[iterations_ - window];
    const double relative = std::abs(before - cost) / std::max(1.0, std::abs(cost));
    if (relative < options_.relative_cost_tolerance) {
      stop_ = Stop::kConverged;
      stop_message_ = Format("relative cost decrease %.3g < tolerance %.3g", relative,
                             options_.relative_cost_tolerance) +
                      " over " + std::to_string(window) + " iterations";
      return stop_;
    }
  }
  if (iterations_ >= options_.max_iterations) {
    stop_ = Stop::kMaxIterations;
    stop_message_ = "reached max_iterations = " + std::to_string(options_.max_iterations);
    return stop_;
  }
  StopIfTimeUp();
  return stop_;
}

bool SolverRun::GradientTest(double gradient_max_norm) {
  if (!(gradient_max_norm <= options_.gradient_tolerance)) return false;  // also for NaN
  stop_ = Stop::kConverged;
  stop_message_ = Format("gradient max-norm %.3g <= tolerance %.3g", gradient_max_norm,
                         options_.gradient_tolerance);
  return true;
}

SolverRun::Stop SolverRun::RefineIterateGradient(const double* x, double gradient_max_norm) {
  if (stop_ != Stop::kNone || !x_known_ || !SameX(x_, x)) return stop_;
  gradient_max_norm_ = gradient_max_norm;
  GradientTest(gradient_max_norm);
  return stop_;
}

bool SolverRun::StopIfStalled(int limit) {
  if (stop_ != Stop::kNone) return true;  // the first reason stands
  const int since = successes_since_iterate_ + failures_since_iterate_;
  if (since < limit) return false;
  if (successes_since_iterate_ == 0) {
    stop_ = Stop::kEvaluationFailed;
    stop_message_ = "the last " + std::to_string(since) +
                    " evaluations failed (or were not finite)";
  } else {
    stop_ = Stop::kLineSearchFailed;
    stop_message_ = "no lower cost in the last " + std::to_string(since) + " evaluations";
  }
  return true;
}

bool SolverRun::StopIfTimeUp() {
  if (stop_ != Stop::kNone) return true;  // the first reason stands
  if (!TimeUp()) return false;
  stop_ = Stop::kTimeout;
  stop_message_ = Format("wall time %.3g s >= max_time_seconds %.3g", Elapsed(),
                         options_.max_time_seconds);
  return true;
}

void SolverRun::SetFinalPoint(const double* x, bool counts_as_step) {
  if (x_known_ && SameX(x_, x)) return;
  double cost = 0.0;
  VecX grad(n_);
  if (!Evaluate(x, &cost, grad.data())) return;
  if (counts_as_step && has_iterate_) ++iterations_;
  has_iterate_ = true;
  x_ = Eigen::Map<const VecX>(x, n_);
  x_known_ = true;
  cost_ = cost;
  gradient_max_norm_ = grad.lpNorm<Eigen::Infinity>();
}

void SolverRun::Finish(opt::SolveStatus status, std::string message,
                       opt::SolveResult* result) const {
  result->status = status;
  result->message = std::move(message);
  result->iterations = iterations_;
  if (has_iterate_ && x_known_) {
    result->x = x_;
    result->cost = cost_;
    result->gradient_max_norm = gradient_max_norm_;
  }
}

opt::SolveStatus SolverRun::StatusOf(Stop stop) {
  switch (stop) {
    case Stop::kMaxIterations: return opt::SolveStatus::kMaxIterations;
    case Stop::kTimeout: return opt::SolveStatus::kTimeout;
    case Stop::kLineSearchFailed: return opt::SolveStatus::kLineSearchFailed;
    case Stop::kEvaluationFailed: return opt::SolveStatus::kEvaluationFailed;
    case Stop::kConverged:
    case Stop::kNone: break;
  }
  return opt::SolveStatus::kConverged;
}

}  // namespace quadhand::solvers

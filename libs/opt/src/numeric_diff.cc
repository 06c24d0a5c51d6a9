#include "quadhand/opt/numeric_diff.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace quadhand::opt {
namespace {

double StepFor(double step, double xi) { return step * std::max(1.0, std::abs(xi)); }

bool ValidStep(double step) { return std::isfinite(step) && step > 0.0; }

}  // namespace

core::Result<VecX> NumericGradient(const Objective& objective, const VecX& x, double step) {
  const int n = objective.num_variables();
  if (x.size() != n)
    return core::Status::InvalidArgument("x has " + std::to_string(x.size()) +
                                         " entries, the objective " + std::to_string(n));
  if (!ValidStep(step)) return core::Status::InvalidArgument("step must be finite and > 0");
  VecX grad(n);
  VecX probe = x;
  for (int i = 0; i < n; ++i) {
    const double h = StepFor(step, x[i]);
    double plus = 0.0;
    double minus = 0.0;
    probe[i] = x[i] + h;
    const bool ok_plus = objective.Evaluate(probe, &plus, nullptr);
    probe[i] = x[i] - h;
    const bool ok_minus = objective.Evaluate(probe, &minus, nullptr);
    probe[i] = x[i];
    if (!ok_plus || !ok_minus || !std::isfinite(plus) || !std::isfinite(minus))
      return core::Status::Internal("evaluation failed while differentiating component " +
                                    std::to_string(i));
    grad[i] = (plus - minus) / (2.0 * h);
  }
  return grad;
}

core::Result<MatX> NumericJacobian(const VectorFunction& function, const VecX& x, double step) {
  if (!function) return core::Status::InvalidArgument("null function");
  if (!ValidStep(step)) return core::Status::InvalidArgument("step must be finite and > 0");
  VecX y0;
  if (!function(x, &y0) || !y0.allFinite())
    return core::Status::Internal("evaluation failed at x");
  MatX jacobian(y0.size(), x.size());
  VecX probe = x;
  VecX plus;
  VecX minus;
  for (int j = 0; j < x.size(); ++j) {
    const double h = StepFor(step, x[j]);
    probe[j] = x[j] + h;
    const bool ok_plus = function(probe, &plus);
    probe[j] = x[j] - h;
    const bool ok_minus = function(probe, &minus);
    probe[j] = x[j];
    if (!ok_plus || !ok_minus || !plus.allFinite() || !minus.allFinite())
      return core::Status::Internal("evaluation failed while differentiating column " +
                                    std::to_string(j));
    if (plus.size() != y0.size() || minus.size() != y0.size())
      return core::Status::Internal("the output size changed while differentiating column " +
                                    std::to_string(j));
    jacobian.col(j) = (plus - minus) / (2.0 * h);
  }
  return jacobian;
}

std::string GradientCheckReport::Describe() const {
  if (worst_index < 0) return "empty gradient";
  char buffer[200];
  std::snprintf(buffer, sizeof(buffer),
                "max relative error %.3g at index %d (analytic %.9g, numeric %.9g)%s",
                max_relative_error, worst_index, analytic[worst_index], numeric[worst_index],
                passed ? "" : ": FAILED");
  return buffer;
}

core::Result<GradientCheckReport> GradientCheck(const Objective& objective, const VecX& x,
                                                const GradientCheckOptions& options) {
  if (!(options.tolerance >= 0.0))
    return core::Status::InvalidArgument("tolerance must be >= 0");
  core::Result<VecX> numeric = NumericGradient(objective, x, options.step);
  if (!numeric.ok()) return numeric.status();
  GradientCheckReport report;
  double cost = 0.0;
  if (!objective.Evaluate(x, &cost, &report.analytic) || !report.analytic.allFinite())
    return core::Status::Internal("analytic gradient evaluation failed");
  report.numeric = std::move(*numeric);
  const int n = static_cast<int>(x.size());
  report.relative_error.resize(n);
  for (int i = 0; i < n; ++i) {
    report.relative_error[i] = std::abs(report.analytic[i] - report.numeric[i]) /
                               std::max(1.0, std::abs(report.numeric[i]));
    if (report.worst_index < 0 || report.relative_error[i] > report.max_relative_error) {
      report.max_relative_error = report.relative_error[i];
      report.worst_index = i;
    }
  }
  report.passed = report.max_relative_error <= options.tolerance;
  return report;
}

}  // namespace quadhand::opt

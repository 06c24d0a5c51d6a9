// Central finite differences for checking analytic derivatives in tests.
//
// Step sizes are relative: component i is perturbed by h_i = step * max(1, |x_i|).
// With central differences the truncation error is O(h^2) and the rounding
// error O(eps |f| / h), so step ~ 1e-6 suits well-scaled smooth functions.
#pragma once

#include <functional>
#include <string>

#include "quadhand/core/status.h"
#include "quadhand/core/types.h"
#include "quadhand/opt/objective.h"

namespace quadhand::opt {

// Gradient of `objective` at x by central differences (2n cost evaluations,
// gradient not requested). InvalidArgument for a bad size or step <= 0;
// Internal when an evaluation fails or is not finite.
core::Result<VecX> NumericGradient(const Objective& objective, const VecX& x,
                                   double step = 1e-6);

// A vector function y = F(x); returns false when it cannot be evaluated.
using VectorFunction = std::function<bool(const VecX& x, VecX* y)>;

// m x n Jacobian dF/dx at x by central differences (m taken from F(x)).
// Same errors as NumericGradient, plus Internal when the output size varies.
core::Result<MatX> NumericJacobian(const VectorFunction& function, const VecX& x,
                                   double step = 1e-6);

struct GradientCheckOptions {
  double step = 1e-6;       // relative finite-difference step, see above
  double tolerance = 1e-6;  // largest acceptable relative error
};

// Analytic against numeric gradient, component by component.
struct GradientCheckReport {
  VecX analytic;
  VecX numeric;
  // |analytic_i - numeric_i| / max(1, |numeric_i|)
  VecX relative_error;
  double max_relative_error = 0.0;
  int worst_index = -1;  // argmax of relative_error (-1 when n = 0)
  bool passed = false;   // max_relative_error <= tolerance

  // e.g. "max relative error 3.1e-02 at index 4 (analytic 1.2, numeric 1.16)".
  std::string Describe() const;
};

// Evaluates the analytic gradient at x and compares it with NumericGradient.
// Errors as NumericGradient, plus Internal when the analytic evaluation fails.
core::Result<GradientCheckReport> GradientCheck(const Objective& objective, const VecX& x,
                                                const GradientCheckOptions& options = {});

}  // namespace quadhand::opt

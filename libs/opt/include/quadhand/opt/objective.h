// A differentiable scalar cost f: R^n -> R, the only thing a Solver sees.
#pragma once

#include <functional>

#include "quadhand/core/types.h"

namespace quadhand::opt {

// Cost and gradient of a problem with a fixed number of variables.
//
// Implementations override DoEvaluate(); callers use Evaluate(), which checks
// sizes first (non-virtual interface). Evaluate() must be safe to call from
// one thread at a time on a const object; solvers never call it concurrently.
class Objective {
 public:
  virtual ~Objective() = default;

  // Dimension n of x (at least 1 for a solvable problem).
  virtual int num_variables() const = 0;

  // Writes f(x) to *cost and, when `grad` is not null, df/dx to *grad
  // (resized to n here before DoEvaluate runs). Returns false when the
  // evaluation failed: x has the wrong size, `cost` is null, the gradient came
  // back with the wrong size, or DoEvaluate reported failure (e.g. x outside
  // the domain). A non-finite cost is not a failure at this level; solvers
  // treat it as "step too long".
  bool Evaluate(const VecX& x, double* cost, VecX* grad) const;

 protected:
  // Called with x.size() == num_variables(), cost != null and, when grad is
  // not null, grad->size() == num_variables() (contents unspecified).
  virtual bool DoEvaluate(const VecX& x, double* cost, VecX* grad) const = 0;
};

// An Objective from a callable, mostly for tests and small problems.
// The callable has the contract of Objective::DoEvaluate.
class FunctionObjective final : public Objective {
 public:
  using Function = std::function<bool(const VecX& x, double* cost, VecX* grad)>;

  FunctionObjective(int num_variables, Function function);

  int num_variables() const override { return num_variables_; }

 protected:
  bool DoEvaluate(const VecX& x, double* cost, VecX* grad) const override;

 private:
  int num_variables_;
  Function function_;
};

}  // namespace quadhand::opt

#include "quadhand/opt/objective.h"

#include <utility>

namespace quadhand::opt {

bool Objective::Evaluate(const VecX& x, double* cost, VecX* grad) const {
  const int n = num_variables();
  if (cost == nullptr || n < 0 || x.size() != n) return false;
  if (grad != nullptr) grad->resize(n);
  if (!DoEvaluate(x, cost, grad)) return false;
  return grad == nullptr || grad->size() == n;
}

FunctionObjective::FunctionObjective(int num_variables, Function function)
    : num_variables_(num_variables), function_(std::move(function)) {}

bool FunctionObjective::DoEvaluate(const VecX& x, double* cost, VecX* grad) const {
  return function_ && function_(x, cost, grad);
}

}  // namespace quadhand::opt

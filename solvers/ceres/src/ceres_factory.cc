// The parts of CeresSolver that do not need Ceres (built with or without it).
#include <memory>

#include "quadhand/opt/solver_registry.h"
#include "quadhand/solvers/ceres_solver.h"

namespace quadhand::solvers {

std::string CeresSolver::name() const {
  return direction_ == Direction::kBfgs ? "ceres:BFGS" : "ceres";
}

core::Status RegisterCeresSolver() {
  static const core::Status status = opt::RegisterSolver(
      "ceres", [](const std::string& argument) -> core::Result<std::unique_ptr<opt::Solver>> {
        CeresSolver::Direction direction = CeresSolver::Direction::kLbfgs;
        if (argument == "BFGS") {
          direction = CeresSolver::Direction::kBfgs;
        } else if (!argument.empty() && argument != "LBFGS") {
          return core::Status::InvalidArgument("unknown Ceres direction '" + argument +
                                               "'; use ceres, ceres:LBFGS or ceres:BFGS");
        }
        return std::unique_ptr<opt::Solver>(std::make_unique<CeresSolver>(direction));
      });
  return status;
}

}  // namespace quadhand::solvers

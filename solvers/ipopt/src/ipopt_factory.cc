// The parts of IpoptSolver that do not need Ipopt (built with or without it).
#include <memory>

#include "quadhand/opt/solver_registry.h"
#include "quadhand/solvers/ipopt_solver.h"

namespace quadhand::solvers {

core::Status RegisterIpoptSolver() {
  static const core::Status status = opt::RegisterSolver(
      "ipopt", [](const std::string& argument) -> core::Result<std::unique_ptr<opt::Solver>> {
        if (!argument.empty())
          return core::Status::InvalidArgument("ipopt takes no argument, got '" + argument + "'");
        return std::unique_ptr<opt::Solver>(std::make_unique<IpoptSolver>());
      });
  return status;
}

}  // namespace quadhand::solvers

// The parts of NloptSolver that do not need NLopt (built with or without it):
// the algorithm names it accepts and why it rejects the others.
#include <algorithm>
#include <memory>

#include "quadhand/opt/solver_registry.h"
#include "quadhand/solvers/nlopt_solver.h"

namespace quadhand::solvers {
namespace {

// Every algorithm of NLopt 2.7 without the NLOPT_ prefix, by what it needs.
const std::vector<std::string>& Supported() {
  static const std::vector<std::string> names = {
      "LD_LBFGS",   "LD_MMA",  "LD_CCSAQ", "LD_SLSQP",           "LD_VAR1",
      "LD_VAR2",    "LD_TNEWTON", "LD_TNEWTON_RESTART", "LD_TNEWTON_PRECOND",
      "LD_TNEWTON_PRECOND_RESTART"};
  return names;
}

const std::vector<std::string>& DerivativeFree() {
  static const std::vector<std::string> names = {
      "GN_DIRECT",      "GN_DIRECT_L",          "GN_DIRECT_L_RAND", "GN_DIRECT_NOSCAL",
      "GN_DIRECT_L_NOSCAL", "GN_DIRECT_L_RAND_NOSCAL", "GN_ORIG_DIRECT", "GN_ORIG_DIRECT_L",
      "LN_PRAXIS",      "GN_CRS2_LM",           "GN_MLSL",          "GN_MLSL_LDS",
      "LN_COBYLA",      "LN_NEWUOA",            "LN_NEWUOA_BOUND",  "LN_NELDERMEAD",
      "LN_SBPLX",       "LN_AUGLAG",            "LN_AUGLAG_EQ",     "LN_BOBYQA",
      "GN_ISRES",       "GN_ESCH",              "GN_AGS"};
  return names;
}

const std::vector<std::string>& GlobalWithGradient() {
  static const std::vector<std::string> names = {"GD_STOGO", "GD_STOGO_RAND"};
  return names;
}

const std::vector<std::string>& MetaAlgorithms() {
  static const std::vector<std::string> names = {"LD_AUGLAG", "LD_AUGLAG_EQ", "AUGLAG",
                                                 "AUGLAG_EQ", "G_MLSL",       "G_MLSL_LDS",
                                                 "GD_MLSL",   "GD_MLSL_LDS"};
  return names;
}

bool Contains(const std::vector<std::string>& names, const std::string& name) {
  return std::find(names.begin(), names.end(), name) != names.end();
}

std::string Join(const std::vector<std::string>& names) {
  std::string joined;
  for (const std::string& name : names) joined += (joined.empty() ? "" : ", ") + name;
  return joined;
}

}  // namespace

std::vector<std::string> NloptSolver::SupportedAlgorithms() { return Supported(); }

core::Result<std::unique_ptr<NloptSolver>> NloptSolver::Create(const std::string& algorithm) {
  const std::string name = algorithm.empty() ? kDefaultAlgorithm : algorithm;
  if (Contains(Supported(), name))
    return std::unique_ptr<NloptSolver>(new NloptSolver(name));
  const std::string supported = "; gradient-based algorithms that run here: " + Join(Supported());
  if (Contains(DerivativeFree(), name))
    return core::Status::InvalidArgument("NLopt algorithm " + name +
                                         " is derivative-free; QuadHand's costs have gradients" +
                                         supported);
  if (Contains(GlobalWithGradient(), name))
    return core::Status::InvalidArgument("NLopt algorithm " + name +
                                         " is a global method that needs finite bounds, which "
                                         "an unconstrained problem has not" +
                                         supported);
  if (Contains(MetaAlgorithms(), name))
    return core::Status::InvalidArgument("NLopt algorithm " + name +
                                         " is a meta-algorithm (constraints or global search) "
                                         "that needs a subsidiary optimiser" +
                                         supported);
  if (name == "LD_LBFGS_NOCEDAL")
    return core::Status::InvalidArgument(
        "NLopt algorithm LD_LBFGS_NOCEDAL is not compiled into NLopt; use LD_LBFGS" + supported);
  if (name.rfind("NLOPT_", 0) == 0)
    return core::Status::InvalidArgument("name the NLopt algorithm without the NLOPT_ prefix, "
                                         "e.g. nlopt:" + name.substr(6));
  return core::Status::InvalidArgument("unknown NLopt algorithm '" + name + "'" + supported);
}

core::Status RegisterNloptSolver() {
  static const core::Status status = opt::RegisterSolver(
      "nlopt", [](const std::string& argument) -> core::Result<std::unique_ptr<opt::Solver>> {
        core::Result<std::unique_ptr<NloptSolver>> solver = NloptSolver::Create(argument);
        if (!solver.ok()) return solver.status();
        return std::unique_ptr<opt::Solver>(std::move(*solver));
      });
  return status;
}

}  // namespace quadhand::solvers

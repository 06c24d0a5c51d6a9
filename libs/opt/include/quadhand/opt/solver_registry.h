// Solvers by name, so that apps and configs pick a back-end without the
// planner naming one. Registration is explicit (see
// solvers::RegisterBuiltinSolvers()); nothing registers itself from a static
// initialiser. All functions are thread-safe.
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "quadhand/core/status.h"
#include "quadhand/opt/solver.h"

namespace quadhand::opt {

// Makes a solver from the part of the requested name after the first ':'
// ("" when there is none), e.g. "LD_MMA" for "nlopt:LD_MMA". Returns an
// InvalidArgument status for an argument it does not understand.
using SolverFactory =
    std::function<core::Result<std::unique_ptr<Solver>>(const std::string& argument)>;

// Adds `name` (non-empty, no ':'). InvalidArgument for a bad name or a null
// factory; InvalidArgument when the name is already registered.
core::Status RegisterSolver(const std::string& name, SolverFactory factory);

// True when `name` (without any ":argument") is registered.
bool IsSolverRegistered(const std::string& name);

// "base" or "base:argument". NotFound, listing the known names, when the base
// is not registered; the factory's status when it rejects the argument.
core::Result<std::unique_ptr<Solver>> CreateSolver(const std::string& name);

// Registered base names, sorted.
std::vector<std::string> SolverNames();

}  // namespace quadhand::opt

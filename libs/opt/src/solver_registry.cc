#include "quadhand/opt/solver_registry.h"

#include <map>
#include <mutex>
#include <utility>

namespace quadhand::opt {
namespace {

struct Registry {
  std::mutex mutex;
  std::map<std::string, SolverFactory> factories;
};

// Constructed on first use, so registering from anywhere is safe.
Registry& GetRegistry() {
  static Registry registry;
  return registry;
}

std::string JoinNames(const std::map<std::string, SolverFactory>& factories) {
  std::string names;
  for (const auto& [name, factory] : factories) {
    if (!names.empty()) names += ", ";
    names += name;
  }
  return names.empty() ? "(none registered)" : names;
}

}  // namespace

core::Status RegisterSolver(const std::string& name, SolverFactory factory) {
  if (name.empty() || name.find(':') != std::string::npos)
    return core::Status::InvalidArgument("bad solver name '" + name +
                                         "': it must be non-empty and contain no ':'");
  if (!factory) return core::Status::InvalidArgument("null factory for solver '" + name + "'");
  Registry& registry = GetRegistry();
  std::lock_guard<std::mutex> lock(registry.mutex);
  if (!registry.factories.emplace(name, std::move(factory)).second)
    return core::Status::InvalidArgument("solver '" + name + "' is already registered");
  return core::Status::Ok();
}

bool IsSolverRegistered(const std::string& name) {
  Registry& registry = GetRegistry();
  std::lock_guard<std::mutex> lock(registry.mutex);
  return registry.factories.count(name) > 0;
}

core::Result<std::unique_ptr<Solver>> CreateSolver(const std::string& name) {
  const std::size_t colon = name.find(':');
  const std::string base = name.substr(0, colon);
  const std::string argument = colon == std::string::npos ? "" : name.substr(colon + 1);
  SolverFactory factory;
  {
    Registry& registry = GetRegistry();
    std::lock_guard<std::mutex> lock(registry.mutex);
    const auto it = registry.factories.find(base);
    if (it == registry.factories.end())
      return core::Status::NotFound("unknown solver '" + name +
                                    "'; known solvers: " + JoinNames(registry.factories));
    factory = it->second;
  }
  core::Result<std::unique_ptr<Solver>> solver = factory(argument);
  if (!solver.ok()) return solver.status().WithPrefix("solver '" + name + "'");
  if (*solver == nullptr)
    return core::Status::Internal("the factory of solver '" + name + "' returned null");
  return solver;
}

std::vector<std::string> SolverNames() {
  Registry& registry = GetRegistry();
  std::lock_guard<std::mutex> lock(registry.mutex);
  std::vector<std::string> names;
  for (const auto& entry : registry.factories) names.push_back(entry.first);
  return names;
}

}  // namespace quadhand::opt

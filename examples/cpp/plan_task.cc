// Loads a task (YAML, docs/task_format.md), plans it with the default options
// and the lbfgs solver, and prints the report (JSON). Exit 0 when the plan
// passed the post-check, 1 when it did not, 2 for bad input.
#include <cstdio>

#include "quadhand/opt/solver_registry.h"
#include "quadhand/planner/plan_output.h"
#include "quadhand/planner/planner.h"
#include "quadhand/planner/planning_context.h"
#include "quadhand/solvers/builtin_solvers.h"

int main(int argc, char** argv) {
  using namespace quadhand;
  if (argc != 2) {
    std::fprintf(stderr, "usage: %s TASK.yaml\n", argv[0]);
    return 2;
  }
  if (core::Status s = solvers::RegisterBuiltinSolvers(); !s.ok()) return 2;
  auto solver = opt::CreateSolver("lbfgs");
  auto context = planner::PlanningContext::Load(argv[1], planner::PlanningContextOptions{});
  if (!context.ok()) {
    std::fprintf(stderr, "error: %s\n", context.status().message().c_str());
    return 2;
  }
  auto result = planner::Plan((*context)->Scene(), (*context)->task(), planner::DefaultPlannerOptions(), **solver);
  if (!result.ok()) {
    std::fprintf(stderr, "error: %s\n", result.status().message().c_str());
    return 2;
  }
  std::printf("%s", planner::PlanReportJson(*result, (*context)->robot(), {argv[1], "lbfgs", "mrc_sdf"}).c_str());
  return result->success ? 0 : 1;
}

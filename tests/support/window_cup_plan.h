// One cold plan of the default window-and-cup task (support/window_cup_scene.h)
// with the default options and our L-BFGS, made once per test binary and
// shared by the tests that check what is done with a plan (replanning, the
// post-check's certificate). Needs quadhand::solver_lbfgs.
#pragma once

#include <gtest/gtest.h>

#include "quadhand/planner/planner.h"
#include "quadhand/solvers/lbfgs_solver.h"
#include "support/window_cup_scene.h"

namespace quadhand::testing {

inline const planner::PlanResult& WindowCupPlan() {
  static const planner::PlanResult plan = [] {
    solvers::LbfgsSolver solver;
    auto result = planner::Plan(WindowCup().Scene(), WindowCup().task, planner::DefaultPlannerOptions(), solver);
    EXPECT_TRUE(result.ok()) << result.status().message();
    EXPECT_TRUE(result->success) << result->message;
    return *result;
  }();
  return plan;
}

}  // namespace quadhand::testing

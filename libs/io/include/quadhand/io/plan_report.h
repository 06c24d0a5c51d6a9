// The report of one plan (docs/plan.md "Report"): outcome, timings, the
// terminal state, the post-check with every check, the attempts, the final
// cost terms and the front-end path, as JSON text.
#pragma once

#include <string>

#include "quadhand/planner/planner.h"
#include "quadhand/planner/planner_config.h"
#include "quadhand/robot/robot_model.h"

namespace quadhand::io {

// What the report records besides the result itself.
struct PlanReportInfo {
  std::string task;            // the task file, or a description of where the task came from
  std::string solver;          // as given (e.g. "lbfgs", "nlopt:LD_MMA")
  std::string representation;  // "mrc_sdf", "esdf", "sfc"
  unsigned seed = 0;
  double representation_build_ms = 0;  // building the scene's representation (once per scene)
  double total_ms = 0;                 // wall time of the whole run that made the plan
  // The configuration planned with (every key), and where it came from (a
  // file, or "defaults"); none recorded when null.
  const planner::PlannerConfig* config = nullptr;
  std::string config_source = "defaults";
};

// The report as pretty-printed JSON text (two-space indent, newline at the end).
std::string PlanReportJson(const planner::PlanResult& result, const robot::RobotModel& robot,
                           const PlanReportInfo& info);

}  // namespace quadhand::io

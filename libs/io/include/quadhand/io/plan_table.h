// The plan as a table of uniform samples (the plan file of
// shared/spec/contracts.md and docs/plan.md): time, base position, velocity,
// acceleration, attitude, yaw and yaw rate, then every actuated joint and
// every joint rate, one row per sample from 0 to the duration inclusive.
#pragma once

#include <string>
#include <vector>

#include "quadhand/core/types.h"
#include "quadhand/planner/whole_body_problem.h"
#include "quadhand/robot/robot_model.h"

namespace quadhand::io {

struct PlanTable {
  std::vector<std::string> columns;  // t, px, ..., yaw_rate, <joint>..., <joint>_rate...
  Eigen::MatrixXd values;            // one row per sample, one column per name
};

// Samples `trajectory` every `dt` seconds (dt > 0), the last row exactly at
// the duration.
PlanTable SamplePlanTable(const planner::WholeBodyTrajectory& trajectory, const robot::RobotModel& robot, double dt);

// The CSV text of the table: a header line, then %.10g values.
std::string PlanTableCsv(const PlanTable& table);

}  // namespace quadhand::io

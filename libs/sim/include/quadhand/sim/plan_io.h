// Plan files (CSV, shared/spec/contracts.md): read, sample between rows, write.
// Columns: t,px,py,pz,vx,vy,vz,ax,ay,az,qw,qx,qy,qz,yaw,yaw_rate, then the
// actuated joints by their URDF names, then "<name>_rate" for each. Columns
// are found by name; extra columns are ignored.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "quadhand/core/status.h"
#include "quadhand/core/types.h"
#include "quadhand/sim/controller.h"

namespace quadhand::sim {

struct PlanRow {
  double t = 0.0;
  Vec3 position = Vec3::Zero();
  Vec3 velocity = Vec3::Zero();
  Vec3 acceleration = Vec3::Zero();
  Quat attitude = Quat::Identity();
  double yaw = 0.0;
  double yaw_rate = 0.0;
  VecX joints;
  VecX joint_rates;
  // The `gripper` column of a mission's plan or flown record (0 open, 1
  // closed); -1 where the file has none.
  int gripper = -1;
  // The `target_*` columns of a moving target's plan or flown record
  // (contracts.md 0.3): the target's pose then - the tool goal's pose moved
  // with the target (docs/moving_targets.md); none where the file has none,
  // and none in an online flight log's rows before the tracker's first
  // estimate (all seven cells blank).
  std::optional<Pose> target;
};

struct Plan {
  std::vector<std::string> joint_names;
  std::vector<PlanRow> rows;  // t strictly increasing, at least 2 rows
  // The file has the seven target_* columns (its rows may still have no
  // target: an online flight log's before its tracker's first estimate).
  bool has_target_columns = false;

  double start_time() const { return rows.front().t; }
  double end_time() const { return rows.back().t; }
};

// Parses a plan; `source` (the file name) starts every error message.
// Errors: missing columns, rows of the wrong width, non-numbers or non-finite
// values (with their line), time not strictly increasing, fewer than 2 rows,
// a `gripper` column (read when there is one) holding other than 0 or 1,
// target_* columns (read when all seven are there) whose quaternion is not
// of unit length (1e-3), or with some of a row's seven cells blank and not
// all.
core::Result<Plan> ParsePlanCsv(const std::string& text, const std::vector<std::string>& joint_names,
                                const std::string& source);
core::Result<Plan> LoadPlanCsv(const std::string& path, const std::vector<std::string>& joint_names);

// The setpoint at time t (clamped to the plan's span): linear interpolation
// between rows (yaw along the shorter arc), jerk from the difference of the
// accelerations of the surrounding rows (zero outside the plan).
Setpoint SamplePlan(const Plan& plan, double t);

// The header line (without newline) of a plan file for these joints, with
// the `gripper` column after the joint rates and then the target's columns
// when asked.
std::string PlanCsvHeader(const std::vector<std::string>& joint_names, bool gripper_column = false,
                          bool target_columns = false);
// One row of numbers in the plan columns' order (no newline, >= 10
// significant digits), then the gripper and the target when the row has them.
std::string PlanCsvRow(const PlanRow& row);
// A whole plan file.
std::string WritePlanCsv(const Plan& plan);

}  // namespace quadhand::sim

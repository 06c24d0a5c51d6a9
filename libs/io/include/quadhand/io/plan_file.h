// The plan file (shared/spec/contracts.md, docs/plan.md): CSV with the
// columns t,px,py,pz,vx,vy,vz,ax,ay,az,qw,qx,qy,qz,yaw,yaw_rate, then every
// actuated joint by its URDF name, then "<joint>_rate" for each; one row per
// sample, time strictly increasing. Written by quadhand-plan and the Python
// module (planner/plan_file.h samples a trajectory into a PlanTable), read by
// quadhand-sim, written again by the simulator and the online flight log.
#pragma once

#include <string>
#include <vector>

#include "quadhand/core/status.h"
#include "quadhand/core/types.h"

namespace quadhand::io {

// The plan file's columns for these actuated joints.
std::vector<std::string> PlanColumns(const std::vector<std::string>& joint_names);

struct PlanTable {
  std::vector<std::string> columns;  // PlanColumns(...) for a plan file
  Eigen::MatrixXd values;            // one row per sample, one column per name
};

// The CSV text of a table: a header line, then the values as %.10g.
std::string PlanTableCsv(const PlanTable& table);

// Appends ",<value>" (just "<value>" to an empty line) as %.10g: for files
// that extend the plan columns with their own (flight logs).
void AppendCsvNumber(std::string* line, double value);

// Parses a plan file for these joints: the plan columns are found by name in
// the header; of the others, those named in `optional_columns` that the
// file has follow them in `columns` and `values` (in that order), and the
// rest are ignored. A blank cell of a column named in `blank_allowed` (an
// online flight log's target before its first estimate) is read as NaN.
// Errors start with `source` and name the line: an empty file, a missing
// column, a row of the wrong width, a value that is not a finite number, a
// quaternion (qw, qx, qy, qz) not of unit length (1e-3), time not strictly
// increasing, fewer than 2 rows.
core::Result<PlanTable> ParsePlanFile(const std::string& text, const std::vector<std::string>& joint_names,
                                      const std::string& source,
                                      const std::vector<std::string>& optional_columns = {},
                                      const std::vector<std::string>& blank_allowed = {});
core::Result<PlanTable> LoadPlanFile(const std::string& path, const std::vector<std::string>& joint_names);

}  // namespace quadhand::io

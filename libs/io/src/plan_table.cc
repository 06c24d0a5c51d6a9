#include "quadhand/io/plan_table.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

namespace quadhand::io {

PlanTable SamplePlanTable(const planner::WholeBodyTrajectory& trajectory, const robot::RobotModel& robot, double dt) {
  PlanTable table;
  table.columns = {"t", "px", "py", "pz", "vx", "vy", "vz", "ax", "ay", "az", "qw", "qx", "qy", "qz", "yaw", "yaw_rate"};
  const std::vector<std::string> names = robot.ActuatedJointNames();
  for (const auto& name : names) table.columns.push_back(name);
  for (const auto& name : names) table.columns.push_back(name + "_rate");

  const double duration = trajectory.duration();
  const long steps = std::max(1L, static_cast<long>(std::ceil(duration / dt - 1e-9)));
  const int n = static_cast<int>(names.size());
  table.values.resize(steps + 1, static_cast<Eigen::Index>(table.columns.size()));
  for (long k = 0; k <= steps; ++k) {
    const double t = k == steps ? duration : k * dt;
    const planner::WholeBodySample s = trajectory.Sample(t);
    auto row = table.values.row(k);
    row[0] = t;
    row.segment<3>(1) = s.position.transpose();
    row.segment<3>(4) = s.velocity.transpose();
    row.segment<3>(7) = s.acceleration.transpose();
    row[10] = s.attitude.w();
    row[11] = s.attitude.x();
    row[12] = s.attitude.y();
    row[13] = s.attitude.z();
    row[14] = s.yaw;
    row[15] = s.yaw_rate;
    row.segment(16, n) = s.joints.transpose();
    row.segment(16 + n, n) = s.joint_rates.transpose();
  }
  return table;
}

std::string PlanTableCsv(const PlanTable& table) {
  std::ostringstream out;
  for (size_t c = 0; c < table.columns.size(); ++c) out << (c == 0 ? "" : ",") << table.columns[c];
  out << '\n';
  char buffer[64];
  for (Eigen::Index r = 0; r < table.values.rows(); ++r) {
    for (Eigen::Index c = 0; c < table.values.cols(); ++c) {
      std::snprintf(buffer, sizeof(buffer), c == 0 ? "%.10g" : ",%.10g", table.values(r, c));
      out << buffer;
    }
    out << '\n';
  }
  return out.str();
}

}  // namespace quadhand::io

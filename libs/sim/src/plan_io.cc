#include "quadhand/sim/plan_io.h"

#include <algorithm>
#include <cmath>

#include "quadhand/core/file_util.h"
#include "quadhand/io/plan_file.h"

namespace quadhand::sim {
namespace {

double WrapAngle(double a) { return std::remainder(a, 2.0 * M_PI); }

}  // namespace

const char* const kTargetColumns[] = {"target_x",  "target_y",  "target_z", "target_qw",
                                      "target_qx", "target_qy", "target_qz"};

std::string PlanCsvHeader(const std::vector<std::string>& joint_names, bool gripper_column, bool target_columns) {
  std::string header;
  for (const std::string& column : io::PlanColumns(joint_names)) header += (header.empty() ? "" : ",") + column;
  if (gripper_column) header += ",gripper";
  if (target_columns) {
    for (const char* column : kTargetColumns) header += std::string(",") + column;
  }
  return header;
}

std::string PlanCsvRow(const PlanRow& r) {
  std::string out;
  io::AppendCsvNumber(&out, r.t);
  for (int i = 0; i < 3; ++i) io::AppendCsvNumber(&out, r.position[i]);
  for (int i = 0; i < 3; ++i) io::AppendCsvNumber(&out, r.velocity[i]);
  for (int i = 0; i < 3; ++i) io::AppendCsvNumber(&out, r.acceleration[i]);
  io::AppendCsvNumber(&out, r.attitude.w());
  io::AppendCsvNumber(&out, r.attitude.x());
  io::AppendCsvNumber(&out, r.attitude.y());
  io::AppendCsvNumber(&out, r.attitude.z());
  io::AppendCsvNumber(&out, r.yaw);
  io::AppendCsvNumber(&out, r.yaw_rate);
  for (int i = 0; i < r.joints.size(); ++i) io::AppendCsvNumber(&out, r.joints[i]);
  for (int i = 0; i < r.joint_rates.size(); ++i) io::AppendCsvNumber(&out, r.joint_rates[i]);
  if (r.gripper >= 0) io::AppendCsvNumber(&out, r.gripper);
  if (r.target) {
    const Quat q(r.target->linear());
    for (int i = 0; i < 3; ++i) io::AppendCsvNumber(&out, r.target->translation()[i]);
    for (double v : {q.w(), q.x(), q.y(), q.z()}) io::AppendCsvNumber(&out, v);
  }
  return out;
}

std::string WritePlanCsv(const Plan& plan) {
  const bool gripper = !plan.rows.empty() && plan.rows.front().gripper >= 0;
  const bool target = !plan.rows.empty() && plan.rows.front().target.has_value();
  std::string out = PlanCsvHeader(plan.joint_names, gripper, target) + "\n";
  for (const PlanRow& row : plan.rows) out += PlanCsvRow(row) + "\n";
  return out;
}

core::Result<Plan> ParsePlanCsv(const std::string& text, const std::vector<std::string>& joint_names,
                                const std::string& source) {
  std::vector<std::string> optional = {"gripper"};
  optional.insert(optional.end(), std::begin(kTargetColumns), std::end(kTargetColumns));
  // An online flight log leaves the target blank until its tracker's first
  // estimate: such a row has no target.
  const std::vector<std::string> blank_allowed(std::begin(kTargetColumns), std::end(kTargetColumns));
  auto table = io::ParsePlanFile(text, joint_names, source, optional, blank_allowed);
  if (!table.ok()) return table.status();
  Plan plan;
  plan.joint_names = joint_names;
  const int n = static_cast<int>(joint_names.size());
  auto column = [&table](const std::string& name) {
    const auto found = std::find(table->columns.begin(), table->columns.end(), name);
    return found == table->columns.end() ? -1 : static_cast<int>(found - table->columns.begin());
  };
  const int gripper_column = column("gripper");
  const bool has_gripper = gripper_column >= 0;
  int target_column = column(kTargetColumns[0]);
  for (int k = 1; k < 7 && target_column >= 0; ++k) {
    if (column(kTargetColumns[k]) != target_column + k) target_column = -1;  // all seven, in order, or none
  }
  plan.has_target_columns = target_column >= 0;
  for (Eigen::Index i = 0; i < table->values.rows(); ++i) {
    const auto v = table->values.row(i);
    PlanRow r;
    r.t = v[0];
    r.position = Vec3(v[1], v[2], v[3]);
    r.velocity = Vec3(v[4], v[5], v[6]);
    r.acceleration = Vec3(v[7], v[8], v[9]);
    r.attitude = Quat(v[10], v[11], v[12], v[13]).normalized();
    r.yaw = v[14];
    r.yaw_rate = v[15];
    r.joints = v.segment(16, n).transpose();
    r.joint_rates = v.segment(16 + n, n).transpose();
    int blank = 0;
    for (int k = 0; k < 7 && target_column >= 0; ++k) blank += std::isnan(v[target_column + k]) ? 1 : 0;
    if (blank != 0 && blank != 7) {
      return core::Status::InvalidArgument(source + ": row " + std::to_string(i + 1) +
                                           ": target_x..target_qz: all seven blank (no estimate yet) or none");
    }
    if (target_column >= 0 && blank == 0) {
      const Quat q(v[target_column + 3], v[target_column + 4], v[target_column + 5], v[target_column + 6]);
      if (std::abs(q.norm() - 1.0) > 1e-3) {
        return core::Status::InvalidArgument(source + ": row " + std::to_string(i + 1) +
                                             ": target_qw..target_qz: not a unit quaternion");
      }
      r.target = MakePose(Vec3(v[target_column], v[target_column + 1], v[target_column + 2]),
                          q.normalized().toRotationMatrix());
    }
    if (has_gripper) {
      const double g = v[gripper_column];
      if (g != 0.0 && g != 1.0) {
        return core::Status::InvalidArgument(source + ": row " + std::to_string(i + 1) +
                                             ": column 'gripper': must be 0 (open) or 1 (closed)");
      }
      r.gripper = static_cast<int>(g);
    }
    plan.rows.push_back(std::move(r));
  }
  return plan;
}

core::Result<Plan> LoadPlanCsv(const std::string& path, const std::vector<std::string>& joint_names) {
  auto text = core::ReadFileToString(path);
  if (!text.ok()) return text.status();
  return ParsePlanCsv(*text, joint_names, path);
}

Setpoint SamplePlan(const Plan& plan, double t) {
  const std::vector<PlanRow>& rows = plan.rows;
  Setpoint sp;
  if (t <= rows.front().t || t >= rows.back().t) {
    const PlanRow& r = t <= rows.front().t ? rows.front() : rows.back();
    sp.position = r.position;
    sp.velocity = r.velocity;
    sp.acceleration = r.acceleration;
    sp.yaw = r.yaw;
    sp.yaw_rate = r.yaw_rate;
    sp.joints = r.joints;
    sp.joint_rates = r.joint_rates;
    return sp;
  }
  const auto it = std::upper_bound(rows.begin(), rows.end(), t, [](double x, const PlanRow& r) { return x < r.t; });
  const PlanRow& b = *it;
  const PlanRow& a = *(it - 1);
  const double dt = b.t - a.t;
  const double s = (t - a.t) / dt;
  sp.position = (1 - s) * a.position + s * b.position;
  sp.velocity = (1 - s) * a.velocity + s * b.velocity;
  sp.acceleration = (1 - s) * a.acceleration + s * b.acceleration;
  sp.jerk = (b.acceleration - a.acceleration) / dt;
  sp.yaw = WrapAngle(a.yaw + s * WrapAngle(b.yaw - a.yaw));
  sp.yaw_rate = (1 - s) * a.yaw_rate + s * b.yaw_rate;
  sp.joints = (1 - s) * a.joints + s * b.joints;
  sp.joint_rates = (1 - s) * a.joint_rates + s * b.joint_rates;
  return sp;
}

}  // namespace quadhand::sim

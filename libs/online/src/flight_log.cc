#include "quadhand/online/flight_log.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "quadhand/io/plan_file.h"
#include "quadhand/planner/moving_scene.h"
#include "quadhand/robot/kinematics.h"
#include "quadhand/traj/flatness.h"

namespace quadhand::online {
namespace {

void Put(std::string* out, double v) {
  char buffer[40];
  std::snprintf(buffer, sizeof(buffer), ",%.10g", v);
  *out += buffer;
}

double Quantile(std::vector<double> v, double p) {
  std::sort(v.begin(), v.end());
  const double x = p * static_cast<double>(v.size() - 1);
  const size_t i = static_cast<size_t>(std::floor(x));
  const size_t j = std::min(i + 1, v.size() - 1);
  return v[i] + (x - static_cast<double>(i)) * (v[j] - v[i]);
}

}  // namespace

void FlightLog::Record(const MeasuredState& measured, const std::optional<Setpoint>& setpoint, Phase phase,
                       const std::optional<Pose>& target, const Vec3& setpoint_shift) {
  if (!samples_.empty() && measured.time <= samples_.back().measured.time) {
    if (measured.time < samples_.back().measured.time) return;  // out of order: dropped
    samples_.pop_back();
  }
  FlightSample sample;
  sample.measured = measured;
  sample.setpoint = setpoint;
  sample.setpoint_shift = setpoint_shift;
  sample.phase = phase;
  sample.target = target;
  if (!samples_.empty()) {
    const FlightSample& last = samples_.back();
    sample.acceleration = (measured.velocity - last.measured.velocity) / (measured.time - last.measured.time);
  }
  samples_.push_back(std::move(sample));
}

std::string FlightLog::Csv(const std::vector<std::string>& joint_names) const {
  return CsvHeader(joint_names) + CsvRows(joint_names, 0, samples_.size());
}

std::string FlightLog::CsvHeader(const std::vector<std::string>& joint_names) const {
  std::string out;
  for (const std::string& column : io::PlanColumns(joint_names)) out += (out.empty() ? "" : ",") + column;
  out += ",sp_px,sp_py,sp_pz,sp_vx,sp_vy,sp_vz,sp_ax,sp_ay,sp_az,sp_yaw,sp_yaw_rate";
  for (const auto& name : joint_names) out += ",sp_" + name;
  for (const auto& name : joint_names) out += ",sp_" + name + "_rate";
  out += ",sp_shift_x,sp_shift_y,sp_shift_z,err_pos,phase";
  if (target_columns_) out += ",target_x,target_y,target_z,target_qw,target_qx,target_qy,target_qz";
  out += "\n";
  return out;
}

std::string FlightLog::CsvRows(const std::vector<std::string>& joint_names, size_t begin, size_t end) const {
  std::string out;
  const size_t n = joint_names.size();
  end = std::min(end, samples_.size());
  for (size_t row = begin; row < end; ++row) {
    const FlightSample& s = samples_[row];
    const MeasuredState& m = s.measured;
    char buffer[40];
    std::snprintf(buffer, sizeof(buffer), "%.10g", m.time);
    out += buffer;
    for (int i = 0; i < 3; ++i) Put(&out, m.position[i]);
    for (int i = 0; i < 3; ++i) Put(&out, m.velocity[i]);
    for (int i = 0; i < 3; ++i) Put(&out, s.acceleration[i]);
    Put(&out, m.attitude.w());
    Put(&out, m.attitude.x());
    Put(&out, m.attitude.y());
    Put(&out, m.attitude.z());
    Put(&out, traj::HopfYawOf(m.attitude));
    Put(&out, traj::HopfYawRateOf(m.attitude, m.body_rate));
    for (size_t k = 0; k < n; ++k) Put(&out, k < static_cast<size_t>(m.joints.size()) ? m.joints[k] : 0.0);
    for (size_t k = 0; k < n; ++k) Put(&out, k < static_cast<size_t>(m.joint_rates.size()) ? m.joint_rates[k] : 0.0);
    if (s.setpoint) {
      const Setpoint& sp = *s.setpoint;
      for (int i = 0; i < 3; ++i) Put(&out, sp.position[i]);
      for (int i = 0; i < 3; ++i) Put(&out, sp.velocity[i]);
      for (int i = 0; i < 3; ++i) Put(&out, sp.acceleration[i]);
      Put(&out, sp.yaw);
      Put(&out, sp.yaw_rate);
      for (size_t k = 0; k < n; ++k) Put(&out, k < static_cast<size_t>(sp.joints.size()) ? sp.joints[k] : 0.0);
      for (size_t k = 0; k < n; ++k) Put(&out, k < static_cast<size_t>(sp.joint_rates.size()) ? sp.joint_rates[k] : 0.0);
      for (int i = 0; i < 3; ++i) Put(&out, s.setpoint_shift[i]);
      Put(&out, (m.position - sp.position).norm());
    } else {
      out += std::string(11 + 2 * n + 3 + 1, ',');
    }
    out += ",";
    out += PhaseName(s.phase);
    if (target_columns_ && s.target) {
      const Quat q(s.target->linear());
      for (int i = 0; i < 3; ++i) Put(&out, s.target->translation()[i]);
      Put(&out, q.w());
      Put(&out, q.x());
      Put(&out, q.y());
      Put(&out, q.z());
    } else if (target_columns_) {
      out += ",,,,,,,";
    }
    out += "\n";
  }
  return out;
}

namespace {

// One judged state: the robot's clearance and closest link (of `robot`),
// and for a mission the held object's clearance and what it had to keep.
struct Judged {
  double clearance = 0.0;
  int link = -1;
  const robot::RobotModel* robot = nullptr;
  double held_clearance = std::numeric_limits<double>::infinity();
  double held_bound = 0.0;
};

template <typename Judge>
FlightMetrics Evaluate(const std::vector<FlightSample>& samples, int num_joints, const Judge& judge,
                       const robot::RobotModel& robot, const planner::Task& task, const Vec3& terminal_position,
                       double reach, double end_time) {
  FlightMetrics metrics;
  std::vector<double> errors;
  bool flown = false;
  double min_clearance = reach;
  std::string closest;
  double last_time = 0.0;
  for (const FlightSample& s : samples) {
    if (s.phase == Phase::kFlying && s.setpoint) errors.push_back((s.measured.position - s.setpoint->position).norm());
    flown = flown || s.phase == Phase::kFlying;
    if (!flown || s.measured.joints.size() != num_joints) continue;
    if (metrics.judged_samples > 0 && s.measured.time - last_time > metrics.max_state_gap) {
      metrics.max_state_gap = s.measured.time - last_time;
      metrics.max_state_gap_time = s.measured.time;
    }
    last_time = s.measured.time;
    ++metrics.judged_samples;
    const Judged j = judge(s);
    if (std::isnan(metrics.min_clearance_time)) metrics.min_clearance_time = s.measured.time;
    if (j.clearance < min_clearance) {
      min_clearance = j.clearance;
      closest = j.link >= 0 && j.robot != nullptr ? j.robot->link(j.link).name : std::string();
      metrics.min_clearance_time = s.measured.time;
    }
    if (std::isfinite(j.held_clearance) && j.held_clearance - j.held_bound < metrics.held_object_margin) {
      metrics.held_object_margin = j.held_clearance - j.held_bound;
      metrics.held_object_min_clearance = j.held_clearance;
      metrics.held_object_min_clearance_time = s.measured.time;
      metrics.held_object_bound = j.held_bound;
    }
  }
  if (metrics.judged_samples > 0 && end_time != kNoEndTime && end_time - last_time > metrics.max_state_gap) {
    metrics.max_state_gap = end_time - last_time;
    metrics.max_state_gap_time = end_time;
  }
  metrics.flying_samples = static_cast<long>(errors.size());
  if (!errors.empty()) {
    double sum = 0.0, sum_sq = 0.0;
    for (double e : errors) {
      sum += e;
      sum_sq += e * e;
    }
    metrics.tracking_mean = sum / errors.size();
    metrics.tracking_rms = std::sqrt(sum_sq / errors.size());
    metrics.tracking_median = Quantile(errors, 0.5);
    metrics.tracking_p95 = Quantile(errors, 0.95);
    metrics.tracking_max = *std::max_element(errors.begin(), errors.end());
  }
  if (flown) {
    metrics.min_clearance = min_clearance;
    metrics.closest_link = closest;
  }
  if (!samples.empty()) {
    const MeasuredState& last = samples.back().measured;
    metrics.final_base_error = (last.position - terminal_position).norm();
    planner::Task at_target = task;
    if (samples.back().target && at_target.tool) at_target.tool->position = samples.back().target->translation();
    if (const auto tool_error = ToolGoalError(robot, at_target, last)) metrics.final_tool_error = *tool_error;
  }
  return metrics;
}

}  // namespace

FlightMetrics EvaluateFlight(const std::vector<FlightSample>& samples, const robot::RobotModel& robot,
                             const env::ExactMeshModel& exact, const planner::Task& task,
                             const Vec3& terminal_position, double reach, double end_time,
                             const MovingJudge& moving) {
  auto judge = [&](const FlightSample& s) {
    Judged j;
    j.robot = &robot;
    j.clearance =
        MeasuredClearance(robot, exact, moving.exact, moving.task_target, s.target, s.measured, reach, &j.link);
    return j;
  };
  return Evaluate(samples, robot.num_actuated(), judge, robot, task, terminal_position, reach, end_time);
}

FlightMetrics EvaluateMissionFlight(const std::vector<FlightSample>& samples, const planner::PlanResult& plan,
                                    const PlanClock& clock, const planner::Task& task, double tolerance, double reach,
                                    double end_time, double frozen_plan_time) {
  const std::vector<planner::MissionLeg>& legs = plan.mission_legs;
  if (legs.empty() || !plan.trajectory) return FlightMetrics{};
  const robot::RobotModel& base = *legs.front().robot;
  const int tool = base.LinkIndex(task.tool_link);
  // The flown state nearest the time the plan left plan time `at`.
  auto nearest_state = [&](double at) -> const MeasuredState* {
    const double when = clock.TimeLeaving(at);
    const FlightSample* nearest = nullptr;
    for (const FlightSample& s : samples) {
      if (s.measured.joints.size() != base.num_actuated()) continue;
      if (nearest == nullptr || std::abs(s.measured.time - when) < std::abs(nearest->measured.time - when)) {
        nearest = &s;
      }
    }
    return nearest != nullptr ? &nearest->measured : nullptr;
  };
  auto flown_tool = [&](const MeasuredState& m) {
    return robot::LinkPose(base, MakePose(m.position, m.attitude.toRotationMatrix()), m.joints, tool);
  };
  // Where each grasped object sits in the flown tool's frame: where the
  // tool was when its grasp began (the object lies at its pose in the task
  // until then), not where the plan meant it to be.
  std::vector<std::optional<Pose>> held_in_tool(task.mission.size());
  for (size_t i = 0; tool >= 0 && i < task.mission.size() && i < plan.steps.size(); ++i) {
    const planner::MissionStep& step = task.mission[i];
    if (step.kind != planner::StepKind::kGrasp || !plan.steps[i].planned) continue;
    if (step.held_at_start) {
      held_in_tool[i] = step.object.pose;
    } else if (const MeasuredState* m = nearest_state(plan.steps[i].start_s)) {
      held_in_tool[i] = flown_tool(*m).inverse() * step.object.pose;
    }
  }
  robot::KinematicsState kinematics;
  auto judge = [&](const FlightSample& s) {
    const MeasuredState& m = s.measured;
    const double t = frozen_plan_time >= 0.0 ? std::min(clock.PlanTime(m.time), frozen_plan_time)
                                             : clock.PlanTime(m.time);
    size_t k = 0;
    while (k + 1 < legs.size() && t > legs[k].end_s) ++k;
    const planner::MissionLeg& leg = legs[k];
    Judged j;
    j.robot = leg.robot;
    j.clearance = MeasuredClearance(*leg.robot, *leg.robot_exact, m, reach, &kinematics, &j.link);
    if (leg.object_exact != nullptr && leg.object_link >= 0) {
      Pose object = kinematics.link_poses[leg.object_link];
      if (leg.held_grasp_step >= 0 && held_in_tool[leg.held_grasp_step]) {
        object = kinematics.link_poses[tool] * *held_in_tool[leg.held_grasp_step];
      }
      j.held_clearance = leg.object_exact->LinkClearance(leg.object_link, object, reach, {});
      j.held_bound = leg.object_clearance - tolerance;
    }
    return j;
  };
  const Vec3 terminal = plan.trajectory->Sample(plan.trajectory->duration()).position;
  FlightMetrics metrics = Evaluate(samples, base.num_actuated(), judge, base, task, terminal, reach, end_time);
  for (size_t i = 0; tool >= 0 && i < task.mission.size() && i < plan.steps.size(); ++i) {
    const planner::MissionStep& step = task.mission[i];
    if (!planner::GripperActsAt(step) || !plan.steps[i].planned) continue;
    const MeasuredState* m = nearest_state(plan.steps[i].start_s);
    if (m == nullptr) continue;
    const Vec3 flown = flown_tool(*m).translation();
    const planner::WholeBodySample planned = plan.trajectory->Sample(plan.steps[i].start_s);
    const Vec3 expected =
        robot::LinkPose(base, planned.BasePose(), planned.joints, tool).translation();
    metrics.gripper_tool_errors.emplace_back(i, (flown - expected).norm());
  }
  return metrics;
}

}  // namespace quadhand::online

#include "quadhand/online/flight_log.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "quadhand/io/plan_file.h"
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

void FlightLog::Record(const MeasuredState& measured, const std::optional<Setpoint>& setpoint, Phase phase) {
  if (!samples_.empty() && measured.time <= samples_.back().measured.time) {
    if (measured.time < samples_.back().measured.time) return;  // out of order: dropped
    samples_.pop_back();
  }
  FlightSample sample;
  sample.measured = measured;
  sample.setpoint = setpoint;
  sample.phase = phase;
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
  out += ",err_pos,phase\n";
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
      Put(&out, (m.position - sp.position).norm());
    } else {
      out += std::string(11 + 2 * n + 1, ',');
    }
    out += ",";
    out += PhaseName(s.phase);
    out += "\n";
  }
  return out;
}

FlightMetrics EvaluateFlight(const std::vector<FlightSample>& samples, const robot::RobotModel& robot,
                             const env::ExactMeshModel& exact, const planner::Task& task,
                             const Vec3& terminal_position, double reach, double end_time) {
  FlightMetrics metrics;
  std::vector<double> errors;
  bool flown = false;
  robot::KinematicsState kinematics;
  double min_clearance = reach;
  int closest = -1;
  double last_time = 0.0;
  for (const FlightSample& s : samples) {
    if (s.phase == Phase::kFlying && s.setpoint) errors.push_back((s.measured.position - s.setpoint->position).norm());
    flown = flown || s.phase == Phase::kFlying;
    if (!flown || s.measured.joints.size() != robot.num_actuated()) continue;
    if (metrics.judged_samples > 0 && s.measured.time - last_time > metrics.max_state_gap) {
      metrics.max_state_gap = s.measured.time - last_time;
      metrics.max_state_gap_time = s.measured.time;
    }
    last_time = s.measured.time;
    ++metrics.judged_samples;
    robot::ComputeKinematics(robot, MakePose(s.measured.position, s.measured.attitude.toRotationMatrix()),
                             s.measured.joints, &kinematics);
    int link = -1;
    const double d = env::WholeBodyClearance(kinematics, exact, reach, {}, &link);
    if (std::isnan(metrics.min_clearance_time)) metrics.min_clearance_time = s.measured.time;
    if (d < min_clearance) {
      min_clearance = d;
      closest = link;
      metrics.min_clearance_time = s.measured.time;
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
    if (closest >= 0) metrics.closest_link = robot.link(closest).name;
  }
  if (!samples.empty()) {
    const MeasuredState& last = samples.back().measured;
    metrics.final_base_error = (last.position - terminal_position).norm();
    if (const auto tool_error = ToolGoalError(robot, task, last)) metrics.final_tool_error = *tool_error;
  }
  return metrics;
}

}  // namespace quadhand::online

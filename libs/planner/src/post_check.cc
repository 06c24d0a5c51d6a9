#include "quadhand/planner/post_check.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <thread>

#include "quadhand/robot/kinematics.h"

namespace quadhand::planner {
namespace {

std::string Format(const char* format, double a, double b, double t) {
  char buffer[160];
  std::snprintf(buffer, sizeof(buffer), format, a, b, t);
  return buffer;
}

// Tracks the worst value of one quantity over the samples.
struct Worst {
  double value = -1e300;
  double time = 0.0;
  void Update(double v, double t) {
    if (v > value) {
      value = v;
      time = t;
    }
  }
};

double WrapAngle(double a) { return std::remainder(a, 2.0 * M_PI); }

// More samples than this is a trajectory far longer than any plan, or a dt
// far finer than any check needs: refused (a failed check) rather than run
// for hours.
constexpr double kMaxPostCheckSamples = 1e6;

}  // namespace

bool PostCheckOptions::IsValid(std::string* why) const {
  for (double v : {dt, clearance_tolerance, limit_tolerance, position_tolerance, angle_tolerance, rate_tolerance,
                   insertion_tolerance, recovery_time}) {
    if (!(std::isfinite(v) && v >= 0.0)) {
      if (why != nullptr) *why = "post-check tolerances must be finite and non-negative";
      return false;
    }
  }
  if (!(dt >= 1e-4)) {
    if (why != nullptr) *why = "post-check dt must be at least 0.0001 s";
    return false;
  }
  if (threads < 0 || threads > 256) {
    if (why != nullptr) *why = "post-check threads must be in [0, 256] (0: all cores)";
    return false;
  }
  return true;
}

std::string PostCheckReport::FirstFailure() const {
  for (const CheckResult& check : checks) {
    if (!check.passed) return check.name + ": " + check.detail;
  }
  return "";
}

// ------------------------------------------------------------------ post-check

PostCheckReport PostCheck(const WholeBodyTrajectory& trajectory, const robot::RobotModel& robot, const Task& task,
                          const BoundaryState& terminal, const InsertionGoal& insertion,
                          const env::CollisionModel& model, const env::ExactMeshModel& exact,
                          const env::SelfCollisionModel* self_collision, const PostCheckOptions& options) {
  PostCheckReport report;
  const Limits& limits = task.limits;
  const int n = robot.num_actuated();
  const std::vector<std::string> joint_names = robot.ActuatedJointNames();
  const double duration = trajectory.duration();
  const double wanted_steps = std::ceil(duration / options.dt - 1e-9);
  if (!(wanted_steps <= kMaxPostCheckSamples)) {  // also a non-finite duration
    report.checks.push_back({CheckKind::kSampling, -1, CheckKindName(CheckKind::kSampling), false, wanted_steps,
                             kMaxPostCheckSamples, 0.0,
                             Format("a %.3g s trajectory needs %.3g samples at dt = %.3g s", duration, wanted_steps,
                                    options.dt) +
                                 Format("; at most %.0f are checked", kMaxPostCheckSamples, 0, 0)});
    report.passed = false;
    return report;
  }
  const int steps = std::max(1, static_cast<int>(wanted_steps));
  const double reach = task.safety_distance + 0.05;

  const bool check_self = self_collision != nullptr && !self_collision->pairs().empty();
  const double self_reach = task.self_safety_distance + 0.02;

  // What one sample measures. The samples are measured on `threads` workers,
  // each writing only its own entries; the reduction below visits them in
  // time order, so the verdict is the same to the last bit for any count.
  struct Measured {
    double t = 0.0;
    WholeBodySample sample;
    double d_exact = 0.0, d_self = 0.0, d_model = 0.0;
    int link = -1, pair = -1;
    Vec3 tool = Vec3::Zero();
  };
  // Blocks of samples bound the memory; within a block, worker `first`
  // takes every `stride`-th sample, so the costly samples (near the scene,
  // at the end of a grasp) are spread over all workers.
  constexpr int kBlock = 4096;
  std::vector<Measured> measured(std::min(steps + 1, kBlock));
  int block_begin = 0, block_end = 0;
  auto measure = [&](int first, int stride) {
    robot::KinematicsState kinematics;
    for (int step = block_begin + first; step < block_end; step += stride) {
      Measured& m = measured[step - block_begin];
      m.t = std::min(duration, step * duration / steps);
      m.sample = trajectory.Sample(m.t);
      robot::ComputeKinematics(robot, m.sample.BasePose(), m.sample.joints, &kinematics);
      m.d_exact = env::WholeBodyClearance(kinematics, exact, reach, {}, &m.link);
      if (check_self) m.d_self = self_collision->MinDistanceLowerBound(kinematics, self_reach, &m.pair);
      int piece = 0;
      double local = 0;
      trajectory.position().LocatePiece(m.t, &piece, &local);
      m.d_model = env::WholeBodyClearance(kinematics, model, reach, env::QueryContext{piece, local});
      if (insertion.enabled) m.tool = kinematics.link_poses[insertion.tool_link].translation();
    }
  };
  const int workers = std::clamp(options.threads > 0 ? options.threads
                                                     : static_cast<int>(std::thread::hardware_concurrency()),
                                 1, std::min(steps + 1, kBlock));

  Worst clearance_deficit, model_deficit, speed, acceleration, yaw_rate, body_rate, joint_excess;
  std::vector<Worst> joint_rate(n);
  double min_exact = reach, min_model = reach;
  int closest = -1;
  std::vector<std::pair<double, double>> tool_track;  // (along line, off line) per sample
  std::vector<double> times;
  std::vector<std::pair<double, double>> exact_track;  // (t, exact clearance) per sample
  double min_self = self_reach;
  int closest_self = -1;
  Worst self_deficit;
  for (block_begin = 0; block_begin <= steps; block_begin = block_end) {
    block_end = std::min(steps + 1, block_begin + kBlock);
    std::vector<std::thread> pool;
    for (int w = 1; w < workers; ++w) pool.emplace_back(measure, w, workers);
    measure(0, workers);
    for (std::thread& worker : pool) worker.join();
  for (int index = 0; index < block_end - block_begin; ++index) {
    const Measured& m = measured[index];
    const double t = m.t;
    const WholeBodySample& s = m.sample;
    if (m.d_exact < min_exact) {
      min_exact = m.d_exact;
      closest = m.link;
    }
    clearance_deficit.Update(-m.d_exact, t);
    exact_track.emplace_back(t, m.d_exact);
    if (check_self) {
      if (m.d_self < min_self) {
        min_self = m.d_self;
        closest_self = m.pair;
      }
      self_deficit.Update(-m.d_self, t);
    }
    min_model = std::min(min_model, m.d_model);
    model_deficit.Update(-m.d_model, t);
    speed.Update(s.velocity.norm() / limits.v_max, t);
    acceleration.Update(s.acceleration.norm() / limits.a_max, t);
    yaw_rate.Update(std::abs(s.yaw_rate) / limits.yaw_rate_max, t);
    body_rate.Update(s.body_rate.head<2>().norm() / limits.body_rate_xy_max, t);
    for (int q = 0; q < n; ++q) {
      joint_rate[q].Update(std::abs(s.joint_rates[q]) / limits.joint_rate_max[q], t);
      joint_excess.Update(std::max(s.joints[q] - limits.joint_upper[q], limits.joint_lower[q] - s.joints[q]), t);
    }
    if (insertion.enabled) {
      const Vec3 offset = m.tool - insertion.tool_position;
      const double along = insertion.direction.dot(offset);
      tool_track.emplace_back(along, (offset - along * insertion.direction).norm());
      times.push_back(t);
    }
  }
  }
  report.min_clearance_exact = min_exact;
  report.min_clearance_model = min_model;
  report.closest_link = closest;

  auto add = [&report](CheckKind kind, int joint, std::string name, bool passed, double value, double bound,
                        double time, std::string detail) {
    report.checks.push_back({kind, joint, std::move(name), passed, value, bound, time, std::move(detail)});
  };
  const double clearance_bound = task.safety_distance - options.clearance_tolerance;
  report.start_clearance_exact = exact_track.front().second;
  report.recovery = options.recovery_time > 0.0 && report.start_clearance_exact < clearance_bound;
  if (!report.recovery) {
    add(CheckKind::kClearance, -1, "clearance", min_exact >= clearance_bound, min_exact, task.safety_distance, clearance_deficit.time,
        Format("exact clearance %.4f m (safety distance %.4f m) at t = %.2f s", min_exact, task.safety_distance,
               clearance_deficit.time) +
            (closest >= 0 ? ", link " + robot.link(closest).name : ""));
  } else {
    // The recovery rule (PostCheckOptions::recovery_time): each sample has
    // its own bound, the start's clearance during the stretch and the safety
    // distance after it; the check reports the sample with the least slack.
    const double start = report.start_clearance_exact;
    const double stretch_bound = start - options.clearance_tolerance;
    double worst_slack = 1e300, worst_value = 0.0, worst_bound = 0.0, worst_time = 0.0;
    for (size_t i = 0; i < exact_track.size(); ++i) {
      const auto& [t, d] = exact_track[i];
      const bool in_stretch = t < options.recovery_time && i + 1 < exact_track.size();
      const double bound = in_stretch ? stretch_bound : clearance_bound;
      if (d - bound < worst_slack) {
        worst_slack = d - bound;
        worst_value = d;
        worst_bound = bound;
        worst_time = t;
      }
    }
    add(CheckKind::kClearance, -1, "clearance", worst_slack >= 0.0, worst_value, worst_bound + options.clearance_tolerance, worst_time,
        Format("recovery from %.4f m at the start (within %.2f s: ", start, options.recovery_time, 0) +
            Format("no lower than %.4f m, then the safety distance %.4f m): ", stretch_bound + options.clearance_tolerance,
                   task.safety_distance, 0) +
            Format("exact clearance %.4f m at t = %.2f s, accepted down to %.4f m", worst_value, worst_time,
                   worst_bound));
  }
  report.min_self_distance = min_self;
  report.closest_self_pair = closest_self;
  if (check_self) {
    std::string pair_names;
    if (closest_self >= 0) {
      const env::LinkPair& pair = self_collision->pairs()[closest_self];
      pair_names = ", links " + robot.link(pair.sampled_link).name + " and " + robot.link(pair.queried_link).name;
    }
    add(CheckKind::kSelfClearance, -1, "self_clearance",
        min_self >= task.self_safety_distance - options.clearance_tolerance, min_self, task.self_safety_distance,
        self_deficit.time,
        Format("robot links %.4f m apart (self-safety distance %.4f m) at t = %.2f s", min_self,
               task.self_safety_distance, self_deficit.time) +
            pair_names);
  }
  const double ratio_bound = 1.0 + options.limit_tolerance;
  auto add_limit = [&](CheckKind kind, int joint, const std::string& name, const Worst& w) {
    report.violations.emplace_back(name, w.value);
    add(kind, joint, name, w.value <= ratio_bound, w.value, 1.0, w.time,
        Format("peak %.3f of the limit (accepted up to %.3f) at t = %.2f s", w.value, ratio_bound, w.time));
  };
  add_limit(CheckKind::kVelocity, -1, "velocity", speed);
  add_limit(CheckKind::kAcceleration, -1, "acceleration", acceleration);
  add_limit(CheckKind::kYawRate, -1, "yaw_rate", yaw_rate);
  add_limit(CheckKind::kBodyRateXY, -1, "body_rate_xy", body_rate);
  for (int q = 0; q < n; ++q) add_limit(CheckKind::kJointRate, q, joint_names[q] + "_rate", joint_rate[q]);
  add(CheckKind::kJointLimits, -1, "joint_limits", joint_excess.value <= 1e-3, joint_excess.value, 0.0, joint_excess.time,
      Format("worst excess %.4f rad beyond a joint limit (accepted up to %.4f) at t = %.2f s", joint_excess.value,
             1e-3, joint_excess.time));

  // Start and end states.
  const WholeBodySample first = trajectory.Sample(0.0), last = trajectory.Sample(duration);
  double start_error = (first.position - task.start.position).norm();
  double start_angle = std::abs(WrapAngle(first.yaw - task.start.yaw));
  double end_angle = std::abs(WrapAngle(last.yaw - terminal.yaw));
  start_angle = std::max(start_angle, (first.joints - task.start.joints).cwiseAbs().maxCoeff());
  end_angle = std::max(end_angle, (last.joints - terminal.joints).cwiseAbs().maxCoeff());
  const double end_error = (last.position - terminal.position).norm();
  const double end_rate = std::max({last.velocity.norm(), std::abs(last.yaw_rate), last.joint_rates.cwiseAbs().maxCoeff()});
  add(CheckKind::kStartState, -1, "start_state", start_error <= options.position_tolerance && start_angle <= options.angle_tolerance, start_error,
      options.position_tolerance, 0.0, Format("position error %.4f m, angle error %.4f rad", start_error, start_angle, 0));
  add(CheckKind::kEndState, -1, "end_state",
      end_error <= options.position_tolerance && end_angle <= options.angle_tolerance && end_rate <= options.rate_tolerance,
      end_error, options.position_tolerance, duration,
      Format("position error %.4f m, angle error %.4f rad, residual rate %.4f", end_error, end_angle, end_rate));

  if (insertion.enabled) {
    // The final approach starts at the last sample where the tool was at least
    // `length` back along the line; from there on it must stay on the line.
    int approach_start = -1;
    for (int i = static_cast<int>(tool_track.size()) - 1; i >= 0; --i) {
      if (tool_track[i].first <= -insertion.length + 1e-3) {
        approach_start = i;
        break;
      }
    }
    if (approach_start < 0) {
      add(CheckKind::kInsertion, -1, "insertion", false, 0.0, insertion.length, 0.0,
          Format("the tool never backs off %.3f m along the insertion line (closest approach start %.3f m)",
                 insertion.length, -tool_track.front().first, 0));
    } else {
      Worst off_line;
      for (size_t i = approach_start; i < tool_track.size(); ++i) off_line.Update(tool_track[i].second, times[i]);
      const double tool_end_error = std::hypot(tool_track.back().first, tool_track.back().second);
      add(CheckKind::kInsertion, -1, "insertion", off_line.value <= options.insertion_tolerance && tool_end_error <= options.position_tolerance,
          off_line.value, options.insertion_tolerance, off_line.time,
          Format("tool up to %.4f m off the insertion line (accepted %.4f m), ends %.4f m from the goal",
                 off_line.value, options.insertion_tolerance, tool_end_error) +
              Format(", over the approach from t = %.2f s", times[approach_start], 0, 0));
    }
  }
  report.passed = true;
  for (const CheckResult& check : report.checks) report.passed = report.passed && check.passed;
  return report;
}

}  // namespace quadhand::planner

#include "quadhand/planner/terminal_state.h"

#include <chrono>
#include <cmath>
#include <random>

#include "quadhand/opt/objective.h"
#include "quadhand/opt/penalty.h"
#include "quadhand/robot/kinematics.h"

namespace quadhand::planner {
namespace {

Pose HoverPose(const Vec3& position, double yaw) {
  return MakePose(position, Eigen::AngleAxisd(yaw, Vec3::UnitZ()).toRotationMatrix());
}

// x = [base position (3), yaw, joints (n)] of a hovering robot.
class TerminalStateObjective final : public opt::Objective {
 public:
  TerminalStateObjective(const robot::RobotModel& robot, const env::CollisionModel& collision, const Task& task,
                         const ToolGoal& tool, int tool_link, const TerminalStateOptions& options)
      : robot_(robot), collision_(collision), task_(task), tool_(tool), tool_link_(tool_link), options_(options),
        goal_rotation_(tool.orientation.toRotationMatrix()) {}

  int num_variables() const override { return 4 + robot_.num_actuated(); }

 protected:
  bool DoEvaluate(const VecX& x, double* cost, VecX* grad) const override {
    const int n = robot_.num_actuated();
    const Vec3 position = x.head<3>();
    const double yaw = x[3];
    const VecX joints = x.tail(n);
    env::StateGradient gradient;
    gradient.SetZero(n);
    scratch_.SetZero(n);
    double total = 0.0;
    robot::ComputeKinematics(robot_, HoverPose(position, yaw), joints, &kinematics_);

    // Tool pose.
    const Pose& tool = kinematics_.link_poses[tool_link_];
    const Vec3 error = tool.translation() - tool_.position;
    const Mat3 M = tool.linear() * goal_rotation_.transpose();
    const double rotation_distance = 0.5 * (3.0 - M.trace());
    total += options_.weight_position * error.squaredNorm() + options_.weight_rotation * rotation_distance;
    env::LinkWrench wrench;
    wrench.force = 2.0 * options_.weight_position * error;
    const Vec3 trace_gradient(M(1, 2) - M(2, 1), M(2, 0) - M(0, 2), M(0, 1) - M(1, 0));
    wrench.torque = -0.5 * options_.weight_rotation * trace_gradient;
    env::AccumulateLinkWrench(robot_, kinematics_, tool_link_, wrench, &gradient);

    // Collision at the goal state and, with an insertion, where it starts.
    const env::PenaltyParameters parameters{task_.safety_distance + options_.collision_margin, 0.01};
    total += options_.weight_collision *
             env::WholeBodyPenalty(robot_, kinematics_, collision_, parameters, {}, &scratch_);
    if (tool_.has_insertion) {
      const Vec3 back = position - tool_.insertion_direction * tool_.insertion_length;
      robot::ComputeKinematics(robot_, HoverPose(back, yaw), joints, &kinematics_);
      total += options_.weight_collision *
               env::WholeBodyPenalty(robot_, kinematics_, collision_, parameters, {}, &scratch_);
    }
    // WholeBodyPenalty added its gradient into scratch_ unweighted: fold it in.
    gradient.position += options_.weight_collision * scratch_.position;
    gradient.rotation += options_.weight_collision * scratch_.rotation;
    gradient.joints += options_.weight_collision * scratch_.joints;

    // Joint limits, with a margin.
    const VecX lower = task_.limits.joint_lower, upper = task_.limits.joint_upper;
    for (int q = 0; q < n; ++q) {
      double slope_high = 0, slope_low = 0;
      total += options_.weight_joint_limits *
               (opt::SmoothedL1(joints[q] - (upper[q] - options_.joint_limit_margin), 0.02, &slope_high) +
                opt::SmoothedL1(lower[q] + options_.joint_limit_margin - joints[q], 0.02, &slope_low));
      gradient.joints[q] += options_.weight_joint_limits * (slope_high - slope_low);
    }
    *cost = total;
    if (grad != nullptr) {
      grad->head<3>() = gradient.position;
      (*grad)[3] = gradient.rotation.z();  // the base turns about world z with the yaw
      grad->tail(n) = gradient.joints;
    }
    return std::isfinite(total);
  }

 private:
  const robot::RobotModel& robot_;
  const env::CollisionModel& collision_;
  const Task task_;      // copies: callers may pass temporaries
  const ToolGoal tool_;
  int tool_link_;
  TerminalStateOptions options_;
  Mat3 goal_rotation_;
  mutable robot::KinematicsState kinematics_;
  mutable env::StateGradient scratch_;
};

}  // namespace

std::unique_ptr<opt::Objective> MakeTerminalStateObjective(const robot::RobotModel& robot,
                                                           const env::CollisionModel& collision,
                                                           const Task& task, const ToolGoal& tool,
                                                           int tool_link, const TerminalStateOptions& options) {
  return std::make_unique<TerminalStateObjective>(robot, collision, task, tool, tool_link, options);
}

bool TerminalStateOptions::IsValid(std::string* why) const {
  auto fail = [why](const char* message) {
    if (why != nullptr) *why = message;
    return false;
  };
  if (restarts < 1) return fail("restarts must be at least 1");
  for (double v : {position_tolerance, angle_tolerance, collision_margin, joint_limit_margin, weight_position,
                   weight_rotation, weight_collision, weight_joint_limits}) {
    if (!(std::isfinite(v) && v >= 0.0)) return fail("tolerances, margins and weights must be finite and >= 0");
  }
  return true;
}

core::Result<TerminalStateResult> FindTerminalState(const robot::RobotModel& robot,
                                                    const env::CollisionModel& collision,
                                                    const ExactClearance& exact, const Task& task,
                                                    const ToolGoal& tool, int tool_link,
                                                    const TerminalStateOptions& options,
                                                    const opt::Solver& solver) {
  if (std::string why; !options.IsValid(&why)) return core::Status::InvalidArgument("terminal-state search: " + why);
  const auto start_time = std::chrono::steady_clock::now();
  const int n = robot.num_actuated();
  TerminalStateObjective objective(robot, collision, task, tool, tool_link, options);
  std::mt19937_64 rng(options.seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  opt::SolverOptions solver_options;
  solver_options.max_iterations = 300;
  solver_options.relative_cost_tolerance = 1e-12;
  solver_options.gradient_tolerance = 1e-9;
  robot::KinematicsState kinematics;
  double best_position = INFINITY, best_angle = INFINITY, best_clearance = -INFINITY;
  for (int restart = 0; restart < options.restarts; ++restart) {
    // Initial guess: random joints and yaw (the start's yaw first), base placed
    // so that the tool sits at its goal position.
    VecX x(4 + n);
    const double yaw = restart == 0 ? task.start.yaw : -M_PI + 2.0 * M_PI * unit(rng);
    for (int q = 0; q < n; ++q) {
      const double lo = task.limits.joint_lower[q] + options.joint_limit_margin;
      const double hi = task.limits.joint_upper[q] - options.joint_limit_margin;
      x[4 + q] = lo + unit(rng) * std::max(0.0, hi - lo);
    }
    const Vec3 tool_offset = robot::LinkPose(robot, HoverPose(Vec3::Zero(), yaw), x.tail(n), tool_link).translation();
    x.head<3>() = tool.position - tool_offset;
    x[3] = yaw;
    const opt::SolveResult solved = solver.Solve(objective, x, solver_options);
    if (!std::isfinite(solved.cost)) continue;
    const VecX& y = solved.x;
    const VecX joints = y.tail(n);
    robot::ComputeKinematics(robot, HoverPose(y.head<3>(), y[3]), joints, &kinematics);
    const Pose& tool_pose = kinematics.link_poses[tool_link];
    const double position_error = (tool_pose.translation() - tool.position).norm();
    const double angle_error = Eigen::AngleAxisd(tool_pose.linear() * tool.orientation.toRotationMatrix().transpose()).angle();
    const double reach = task.safety_distance + 0.05;
    double clearance = exact.WholeBody(kinematics, reach, nullptr);
    if (tool.has_insertion) {
      robot::ComputeKinematics(robot, HoverPose(y.head<3>() - tool.insertion_direction * tool.insertion_length, y[3]),
                               joints, &kinematics);
      clearance = std::min(clearance, exact.WholeBody(kinematics, reach, nullptr));
    }
    bool within_limits = true;
    for (int q = 0; q < n; ++q) {
      within_limits = within_limits && joints[q] >= task.limits.joint_lower[q] && joints[q] <= task.limits.joint_upper[q];
    }
    if (position_error < best_position) {
      best_position = position_error;
      best_angle = angle_error;
      best_clearance = clearance;
    }
    if (position_error <= options.position_tolerance && angle_error <= options.angle_tolerance &&
        clearance >= task.safety_distance && within_limits) {
      TerminalStateResult result;
      result.state.position = y.head<3>();
      result.state.yaw = y[3];
      result.state.joints = joints;
      result.state.joint_rates = VecX::Zero(n);
      result.position_error = position_error;
      result.angle_error = angle_error;
      result.clearance = clearance;
      result.restarts_used = restart + 1;
      result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_time).count();
      return result;
    }
  }
  char message[256];
  std::snprintf(message, sizeof(message),
                "no collision-free whole-body state puts the tool at its goal pose (%d restarts; best: "
                "position error %.4f m, angle error %.4f rad, clearance %.4f m)",
                options.restarts, best_position, best_angle, best_clearance);
  return core::Status::Infeasible(message);
}

}  // namespace quadhand::planner

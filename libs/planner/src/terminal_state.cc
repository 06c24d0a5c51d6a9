#include "quadhand/planner/terminal_state.h"

#include <chrono>
#include <cmath>
#include <random>

#include "quadhand/opt/objective.h"
#include "quadhand/planner/cost_term.h"
#include "quadhand/robot/kinematics.h"
#include "terms/builtin_terms.h"
#include "terms/rotation_distance.h"

namespace quadhand::planner {
namespace {

// The whole-body cost options the terminal state's terms are built from: the
// same collision and joint-limit penalties the trajectory is optimised
// with, at the search's own threshold, margin and smoothing.
WholeBodyCostOptions TermOptions(const Task& task, const TerminalStateOptions& options) {
  WholeBodyCostOptions cost;
  cost.collision_threshold = task.safety_distance + options.collision_margin;
  cost.insertion_collision_threshold = 0.0;  // the search never sets SampleState::insertion_piece
  cost.collision_mu = options.collision_mu;
  cost.joint_limit_margin = options.joint_limit_margin;
  cost.joint_limit_mu = options.joint_limit_mu;
  return cost;
}

// x = [base position (3), yaw, joints (n)] of a hovering robot. The tool-pose
// error is the search's own (squared distance and rotation distance to the
// goal, no tolerance); collision and joint limits are the cost terms of
// cost_term.h evaluated at one state (quadrature weight 1).
class TerminalStateObjective final : public opt::Objective {
 public:
  TerminalStateObjective(const robot::RobotModel& robot, const env::CollisionModel& collision, const Task& task,
                         const ToolGoal& tool, int tool_link, const TerminalStateOptions& options)
      : robot_(robot), tool_(tool), tool_link_(tool_link), options_(options),
        goal_rotation_(tool.orientation.toRotationMatrix()), start_yaw_(task.start.yaw), limits_(task.limits),
        cost_options_(TermOptions(task, options)) {
    const CostTermInputs inputs{robot, collision, limits_, no_insertion_, cost_options_};
    collision_ = CollisionTerm().make(inputs, options.weight_collision);
    joint_limits_ = JointLimitTerm().make(inputs, options.weight_joint_limits);
    const int n = robot.num_actuated();
    aux_value_.resize(1 + n);
    aux_rate_ = VecX::Zero(1 + n);
    gradient_.aux_value.resize(1 + n);
    gradient_.aux_rate.resize(1 + n);
  }

  int num_variables() const override { return 4 + robot_.num_actuated(); }

 protected:
  bool DoEvaluate(const VecX& x, double* cost, VecX* grad) const override {
    const int n = robot_.num_actuated();
    const Vec3 position = x.head<3>();
    const double yaw = x[3];
    SampleGradient& g = gradient_;
    g.position.setZero();
    g.rotation.setZero();
    g.aux_value.setZero();
    g.aux_rate.setZero();
    g.point.SetZero(n);
    g.scratch.SetZero(n);
    aux_value_ << yaw, x.tail(n);
    SampleState s;
    s.piece = -1;  // no trajectory piece: corridor models query without a polytope
    s.weight = 1.0;
    s.position = position;
    s.yaw = yaw;
    s.aux_value = &aux_value_;
    s.aux_rate = &aux_rate_;
    s.kinematics = &kinematics_;
    double breakdown = 0.0, sample = 0.0, total = 0.0;
    SampleSums sums{breakdown, sample, total};
    SampleGradient* gradient = grad != nullptr ? &g : nullptr;
    robot::ComputeKinematics(robot_, HoverPose(position, yaw), x.tail(n), &kinematics_);

    // Tool pose.
    const Pose& tool = kinematics_.link_poses[tool_link_];
    const Vec3 error = tool.translation() - tool_.position;
    const RotationDistance rotation = RotationDistanceTo(tool.linear(), goal_rotation_);
    total += options_.weight_position * error.squaredNorm() + options_.weight_rotation * rotation.value +
             options_.weight_turn * (1.0 - std::cos(yaw - start_yaw_));
    if (gradient != nullptr) {
      env::LinkWrench wrench;
      wrench.force = 2.0 * options_.weight_position * error;
      wrench.torque = options_.weight_rotation * rotation.gradient;
      env::AccumulateLinkWrench(robot_, kinematics_, tool_link_, wrench, &g.point);
    }

    // Collision at the goal state and, with an insertion, where it starts.
    collision_->AddSample(s, &sums, gradient);
    if (tool_.has_insertion) {
      s.position = position - tool_.insertion_direction * tool_.insertion_length;
      robot::ComputeKinematics(robot_, HoverPose(s.position, yaw), x.tail(n), &kinematics_);
      collision_->AddSample(s, &sums, gradient);
    }
    joint_limits_->AddSample(s, &sums, gradient);
    total += sample;
    *cost = total;
    if (grad != nullptr) {
      grad->head<3>() = g.position + g.point.position;
      // The base turns about world z with the yaw.
      (*grad)[3] = g.rotation.z() + g.point.rotation.z() + g.aux_value[0] + options_.weight_turn * std::sin(yaw - start_yaw_);
      grad->tail(n) = g.aux_value.tail(n) + g.point.joints;
    }
    return std::isfinite(total);
  }

 private:
  const robot::RobotModel& robot_;
  const ToolGoal tool_;  // a copy: callers may pass temporaries
  int tool_link_;
  TerminalStateOptions options_;
  Mat3 goal_rotation_;
  double start_yaw_;
  const Limits limits_;
  const WholeBodyCostOptions cost_options_;
  const InsertionGoal no_insertion_;
  std::unique_ptr<CostTerm> collision_, joint_limits_;
  mutable robot::KinematicsState kinematics_;
  mutable VecX aux_value_, aux_rate_;
  mutable SampleGradient gradient_;
};

// Where restarts draw actuated joint q from: its limits less the margin; a
// side without a limit (a continuous joint, or a URDF without <limit>) is a
// half turn from the other side or from 0 for a rotational joint, half a
// metre for a prismatic one, so that a seed is always finite.
std::pair<double, double> SeedInterval(const robot::RobotModel& robot, const Task& task, int q, double margin) {
  const robot::Joint& joint = robot.joint(robot.JointIndex(robot.ActuatedJointNames()[q]));
  const double span = joint.type == robot::JointType::kPrismatic ? 0.5 : M_PI;
  double lo = task.limits.joint_lower[q] + margin, hi = task.limits.joint_upper[q] - margin;
  if (!std::isfinite(lo) && !std::isfinite(hi)) return {-span, span};
  if (!std::isfinite(lo)) lo = hi - 2.0 * span;
  if (!std::isfinite(hi)) hi = lo + 2.0 * span;
  return {lo, std::max(lo, hi)};
}

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
  for (double v : {position_tolerance, angle_tolerance, collision_margin, clearance_tolerance, joint_limit_margin, weight_position,
                   weight_rotation, weight_collision, weight_joint_limits, weight_turn, collision_mu, joint_limit_mu}) {
    if (!(std::isfinite(v) && v >= 0.0)) return fail("tolerances, margins and weights must be finite and >= 0");
  }
  return true;
}

core::Result<TerminalStateResult> FindTerminalState(const robot::RobotModel& robot,
                                                    const env::CollisionModel& collision,
                                                    const env::CollisionModel& exact, const Task& task,
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
      const auto [lo, hi] = SeedInterval(robot, task, q, options.joint_limit_margin);
      x[4 + q] = lo + unit(rng) * (hi - lo);
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
    const double reach = ClearanceSearchReach(task);
    double clearance = env::WholeBodyClearance(kinematics, exact, reach, {}, nullptr);
    if (tool.has_insertion) {
      robot::ComputeKinematics(robot, HoverPose(y.head<3>() - tool.insertion_direction * tool.insertion_length, y[3]),
                               joints, &kinematics);
      clearance = std::min(clearance, env::WholeBodyClearance(kinematics, exact, reach, {}, nullptr));
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
        clearance >= AcceptedClearance(task, options.clearance_tolerance) && within_limits) {
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
                "no whole-body state keeping the safety distance puts the tool at its goal pose (%d restarts; best: "
                "position error %.4f m, angle error %.4f rad, clearance %.4f m)",
                options.restarts, best_position, best_angle, best_clearance);
  return core::Status::Infeasible(message);
}

}  // namespace quadhand::planner

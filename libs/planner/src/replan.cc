#include "quadhand/planner/replan.h"

#include <algorithm>
#include <cmath>
#include <memory>

#include "quadhand/robot/kinematics.h"

#include "plan_stages.h"

namespace quadhand::planner {

bool ReplanOptions::IsValid(std::string* why) const {
  std::string inner;
  if (!solver.IsValid(&inner)) {
    if (why != nullptr) *why = "replan solver: " + inner;
    return false;
  }
  if (max_attempts < 1) {
    if (why != nullptr) *why = "replan max_attempts must be at least 1";
    return false;
  }
  if (!(std::isfinite(min_piece_duration) && min_piece_duration > 0.0)) {
    if (why != nullptr) *why = "replan min_piece_duration must be positive";
    return false;
  }
  if (!(std::isfinite(max_start_penetration) && max_start_penetration >= 0.0)) {
    if (why != nullptr) *why = "replan max_start_penetration must be non-negative";
    return false;
  }
  if (!(std::isfinite(recovery_time) && recovery_time > 0.0)) {
    if (why != nullptr) *why = "replan recovery_time must be positive";
    return false;
  }
  return true;
}

ReplanOptions DefaultReplanOptions() {
  ReplanOptions options;
  // Measured on the default task (docs/online.md, quadhand-replan-latency):
  // from a guess 5-20 cm off, 40 iterations with this cost test pass the
  // post-check about as often as 150 (a few percent fewer), at a fraction
  // of the time; a failed first solve is retried with more iterations.
  options.solver.max_iterations = 40;
  options.solver.relative_cost_tolerance = 1e-3;
  options.solver.relative_cost_window = 2;
  options.solver.gradient_tolerance = 1e-4;
  options.solver.max_time_seconds = 0.2;
  options.solver.memory_size = 8;
  return options;
}

core::Status RemainderGuess(const WholeBodyTrajectory& trajectory, double t_from, double min_piece_duration,
                            MatX* position_waypoints, MatX* aux_waypoints, VecX* durations, int* first_piece) {
  const traj::Minco& position = trajectory.position();
  const traj::Minco& aux = trajectory.aux();
  const VecX& T = position.durations();
  const int N = static_cast<int>(T.size());
  if (!(t_from >= 0.0 && t_from < trajectory.duration())) {
    return core::Status::InvalidArgument("replanning time " + std::to_string(t_from) + " s is outside the plan [0, " +
                                         std::to_string(trajectory.duration()) + ")");
  }
  int piece = 0;
  double local = 0.0;
  position.LocatePiece(t_from, &piece, &local);
  double first_duration = std::max(0.0, T[piece] - local);
  // `last` is the last old piece folded into the new first piece.
  int last = piece;
  if (first_duration < min_piece_duration && piece + 1 < N) {
    ++last;
    first_duration += T[last];
  }
  const int pieces = N - last;
  if (pieces == 1) first_duration = std::max(first_duration, min_piece_duration);
  durations->resize(pieces);
  (*durations)[0] = first_duration;
  for (int i = 1; i < pieces; ++i) (*durations)[i] = T[last + i];
  position_waypoints->resize(3, pieces - 1);
  aux_waypoints->resize(aux.dims(), pieces - 1);
  for (int i = 0; i + 1 < pieces; ++i) {
    const int junction_piece = last + i;  // the junction at the end of this old piece
    position_waypoints->col(i) = position.Evaluate(junction_piece, T[junction_piece], 0);
    aux_waypoints->col(i) = aux.Evaluate(junction_piece, T[junction_piece], 0);
  }
  if (first_piece != nullptr) *first_piece = piece;
  return core::Status::Ok();
}

core::Result<PlanResult> Replan(const PlanningScene& scene, const Task& task, const PlannerOptions& options,
                                const ReplanOptions& replan, const opt::Solver& solver, const PlanResult& current,
                                double t_from, const BoundaryState& start) {
  if (std::string why; !options.IsValid(&why)) return core::Status::InvalidArgument("planner options: " + why);
  if (std::string why; !replan.IsValid(&why)) return core::Status::InvalidArgument(why);
  if (!current.trajectory) return core::Status::InvalidArgument("replanning needs a current trajectory");
  const robot::RobotModel& robot = scene.robot;
  const int n = robot.num_actuated();
  if (start.joints.size() != n) {
    return core::Status::InvalidArgument("start state has " + std::to_string(start.joints.size()) +
                                         " joint values, the robot has " + std::to_string(n));
  }
  if (!start.position.allFinite() || !start.velocity.allFinite() || !start.acceleration.allFinite() ||
      !start.jerk.allFinite() || !std::isfinite(start.yaw) || !std::isfinite(start.yaw_rate) ||
      !start.joints.allFinite() || !start.joint_rates.allFinite()) {
    return core::Status::InvalidArgument("start state is not finite");
  }
  const WholeBodyTrajectory& trajectory = *current.trajectory;
  PlanResult result;
  result.terminal = current.terminal;
  result.terminal_searched = current.terminal_searched;
  result.terminal_search = current.terminal_search;
  result.insertion = current.insertion;

  InitialGuess guess;
  int first_piece = 0;
  QUADHAND_RETURN_IF_ERROR(RemainderGuess(trajectory, t_from, replan.min_piece_duration, &guess.position_waypoints,
                                          &guess.aux_waypoints, &guess.durations, &first_piece));
  const int old_pieces = trajectory.num_pieces();
  if (current.insertion.enabled) {
    // The insertion piece must start backed off the full length above the
    // goal; a start inside it, or too close before it to keep a proper first
    // piece, cannot give a plan that passes the insertion check.
    const bool inside = first_piece == old_pieces - 1;
    const bool merged_into_insertion = guess.durations.size() == 1;
    if (inside || merged_into_insertion) {
      result.status = PlanStatus::kInsertionInProgress;
      result.message = "the current plan is in (or about to start) its insertion piece: not replanned";
      return result;
    }
  }

  Task replan_task = task;
  replan_task.start = start;
  if (replan_task.start.joint_rates.size() == 0) replan_task.start.joint_rates = VecX::Zero(n);
  // The measured yaw, unwrapped next to the plan's (the plan may have turned
  // past +-pi; the terminal yaw is unwrapped relative to the plan).
  const double plan_yaw = trajectory.Sample(t_from).yaw;
  replan_task.start.yaw = plan_yaw + std::remainder(start.yaw - plan_yaw, 2.0 * M_PI);

  // A start inside the safety margin is replanned under the recovery rule
  // (replan.h); only a start deeper in the scene than max_start_penetration
  // is refused: no plan from there can be trusted.
  {
    int link = -1;
    const double clearance = StateClearance(scene, replan_task.start, task.safety_distance + 0.05, &link);
    if (clearance < -replan.max_start_penetration) {
      result.status = PlanStatus::kStartInCollision;
      result.message = "the start state is " + std::to_string(clearance) + " m from the scene (link " +
                       (link >= 0 ? robot.link(link).name : std::string("?")) + ", at most " +
                       std::to_string(replan.max_start_penetration) + " m inside it is recovered from)";
      return result;
    }
  }

  result.num_pieces = static_cast<int>(guess.durations.size());
  // Corridors (sfc) along the remaining piece boundaries: there is no front-end path.
  PlanCollision collision;
  auto built = BuildPlanCollision(scene, {}, replan_task.start.position, guess, result.terminal.position, &collision,
                                  &result);
  if (!built.ok()) return built.status();
  if (!*built) return result;
  // The post-check of Plan() plus the recovery rule, which changes nothing
  // for a start outside the safety margin.
  PlannerOptions checked = options;
  checked.post_check.recovery_time = replan.recovery_time;
  // Re-solves of a replan raise weights only; they keep the sample count
  // (measured with that rule: docs/online.md).
  checked.resolve_sample_factor = 1;
  const SolveSchedule schedule{solver, replan.solver, options.solver, replan.max_attempts};
  QUADHAND_RETURN_IF_ERROR(Optimise(scene, collision, replan_task, guess, checked, schedule, &result));
  return result;
}

}  // namespace quadhand::planner

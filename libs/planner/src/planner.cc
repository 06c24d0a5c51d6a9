#include "quadhand/planner/planner.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <iterator>
#include <limits>
#include <optional>

#include "quadhand/core/text.h"
#include "quadhand/planner/cost_term.h"
#include "plan_stages.h"
#include "quadhand/robot/kinematics.h"

namespace quadhand::planner {
namespace {

// ResolveMovingGoal samples when a target could be met this often (s).
constexpr double kReachStep = 0.05;

double MillisecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

// Whether the plan's goal moves with the target: the goal was resolved as a
// moving one against a scene whose goal moves.
bool MovesTheGoal(const PlanningScene& scene, const PlanResult& result) {
  return result.moving_target && scene.moving != nullptr && scene.moving->goal_moves;
}

// What of the scene moves for this plan: everything of a moving goal's
// scene, or the points alone (a mission's leg past them to a still goal).
const MovingScene* MovingPartOf(const PlanningScene& scene, const PlanResult& result) {
  if (scene.moving == nullptr) return nullptr;
  return MovesTheGoal(scene, result) || !scene.moving->goal_moves ? scene.moving : nullptr;
}

}  // namespace

bool MissionPlanOptions::IsValid(std::string* why) const {
  auto fail = [why](const char* message) {
    if (why != nullptr) *why = message;
    return false;
  };
  if (!(object_sdf_resolution >= 5e-4 && object_sdf_resolution <= 0.05)) {
    return fail("mission.object_sdf_resolution must be in [0.0005, 0.05] m");
  }
  if (!(object_sdf_padding >= 0.02 && object_sdf_padding <= 0.5)) return fail("mission.object_sdf_padding must be in [0.02, 0.5] m");
  if (!(released_surface_spacing >= 5e-4 && released_surface_spacing <= 0.05)) {
    return fail("mission.released_surface_spacing must be in [0.0005, 0.05] m");
  }
  if (!(move_speed > 0.0 && move_speed <= 10.0)) return fail("mission.move_speed must be in (0, 10] m/s");
  if (!(move_min_duration >= 0.0 && move_min_duration <= 60.0)) return fail("mission.move_min_duration must be in [0, 60] s");
  return true;
}

bool PlannerOptions::IsValid(std::string* why) const {
  auto fail = [why](const char* message) {
    if (why != nullptr) *why = message;
    return false;
  };
  std::string inner;
  if (!cost.IsValid(&inner) || !solver.IsValid(&inner) || !post_check.IsValid(&inner) || !mission.IsValid(&inner)) {
    if (why != nullptr) *why = inner;
    return false;
  }
  if (!(collision_margin >= 0.0 && std::isfinite(collision_margin))) return fail("collision_margin must be >= 0");
  if (!(insertion_collision_margin >= 0.0 && std::isfinite(insertion_collision_margin))) {
    return fail("insertion_collision_margin must be >= 0");
  }
  if (!(self_collision_margin >= 0.0 && std::isfinite(self_collision_margin))) {
    return fail("self_collision_margin must be >= 0");
  }
  if (!(piece_length > 0.0 && std::isfinite(piece_length))) return fail("piece_length must be positive");
  if (min_pieces < 2) return fail("min_pieces must be at least 2");
  if (!(cruise_speed > 0.0 && cruise_acceleration > 0.0)) return fail("cruise speed and acceleration must be positive");
  if (!(stow_margin >= 0.0 && stow_lead >= 0.0 && std::isfinite(stow_lead))) return fail("stow_margin and stow_lead must be >= 0");
  if (max_attempts < 1) return fail("max_attempts must be at least 1");
  if (alternative_guesses < 0 || alternative_guesses > 3) return fail("alternative_guesses must be in [0, 3]");
  if (section_pieces != 0 && (section_pieces < 2 || section_pieces > 100000)) {
    return fail("section_pieces must be 0 (never) or in [2, 100000]");
  }
  if (!(weight_raise_factor >= 1.0)) return fail("weight_raise_factor must be at least 1");
  if (resolve_sample_factor < 1) return fail("resolve_sample_factor must be at least 1");
  if (max_samples_per_piece < 1 || max_samples_per_piece > 1000) {
    return fail("max_samples_per_piece must be in [1, 1000]");
  }
  return true;
}

PlannerOptions DefaultPlannerOptions() {
  PlannerOptions options;
  options.solver.max_iterations = 150;
  // Converged when the cost fell by less than 1 % over the last 10 accepted
  // steps: the tail of this problem is long and flat (docs/benchmark.md,
  // "Tuning history").
  options.solver.relative_cost_tolerance = 1e-2;
  options.solver.relative_cost_window = 10;
  options.solver.gradient_tolerance = 1e-5;
  options.solver.max_time_seconds = 10.0;
  options.solver.memory_size = 48;
  return options;
}

WholeBodyCostOptions CostForTask(const PlannerOptions& options, const Task& task) {
  WholeBodyCostOptions cost = options.cost;
  cost.collision_threshold = task.safety_distance + options.collision_margin;
  cost.insertion_collision_threshold = task.safety_distance + options.insertion_collision_margin;
  cost.self_collision_threshold = task.self_safety_distance + options.self_collision_margin;
  return cost;
}

bool RaiseWeightsOfFailedChecks(const PostCheckReport& report, double factor, int sample_factor, int max_samples,
                                WholeBodyCostOptions* cost) {
  // Several terms share one weight (the still and the moving scene's
  // collision), and several failed checks can name one term: each weight is
  // raised once per re-solve, however many of them ask.
  std::vector<double WholeBodyCostOptions::*> to_raise;
  bool clearance_failed = false;
  for (const CheckResult& check : report.checks) {
    if (check.passed) continue;
    clearance_failed = clearance_failed || check.kind == CheckKind::kClearance;
    // Each term declares the checks that raise its weight; start and end
    // states raise none (MINCO meets the boundary conditions exactly).
    for (const CostTermDescriptor& term : CostTermDescriptors()) {
      const auto& kinds = term.raised_by;
      if (std::find(kinds.begin(), kinds.end(), check.kind) == kinds.end()) continue;
      if (std::find(to_raise.begin(), to_raise.end(), term.weight) == to_raise.end()) to_raise.push_back(term.weight);
    }
  }
  // A thin link can pass an obstacle edge between two samples of a long
  // piece, where no weight on the sampled penalty sees it.
  if (clearance_failed) {
    for (int* samples : {&cost->samples_per_piece, &cost->insertion_samples}) {
      *samples = std::max(*samples, std::min(*samples * sample_factor, max_samples));
    }
  }
  for (double WholeBodyCostOptions::*weight : to_raise) cost->*weight *= factor;
  return !to_raise.empty();
}

core::Status SolveAndPostCheck(WholeBodyProblem* problem, const VecX& x0, const PlanningScene& scene,
                               const env::CollisionModel& collision, const Task& task,
                               const PlannerOptions& options, const SolveSchedule& schedule, PlanResult* result) {
  if (problem == nullptr || result == nullptr) return core::Status::InvalidArgument("no problem or result");
  if (x0.size() != problem->num_variables()) return core::Status::InvalidArgument("initial guess has the wrong size");
  for (const opt::SolverOptions* o : {&schedule.first, &schedule.retry}) {
    if (std::string why; !o->IsValid(&why)) return core::Status::InvalidArgument("solver options: " + why);
  }
  WholeBodyCostOptions cost = problem->options();
  VecX x = x0;
  result->success = false;
  for (int attempt = 0; attempt < schedule.max_attempts; ++attempt) {
    const opt::SolveResult solved = schedule.solver.Solve(*problem, x, attempt == 0 ? schedule.first : schedule.retry);
    PlanAttempt record;
    record.solve_ms = solved.wall_time_seconds * 1e3;
    record.iterations = solved.iterations;
    record.evaluations = solved.evaluations;
    record.solver_status = solved.status;
    result->solve_ms += record.solve_ms;
    result->iterations += solved.iterations;
    result->evaluations += solved.evaluations;
    auto trajectory = problem->Trajectory(solved.x);
    if (!std::isfinite(solved.cost) || !trajectory.ok()) {
      record.post_check_failure = "solver returned no usable trajectory (" + solved.message + ")";
      result->attempts.push_back(record);
      result->status = PlanStatus::kSolverFailed;
      result->message = record.post_check_failure;
      return core::Status::Ok();
    }
    x = solved.x;
    const auto check_start = std::chrono::steady_clock::now();
    // A solve that is followed by another when it fails only needs to know
    // that it failed, and which checks: its check stops at the first failing
    // clearance (PostCheckOptions::stop_at_first_failure).
    PostCheckOptions check = options.post_check;
    check.stop_at_first_failure = check.stop_at_first_failure || attempt + 1 < schedule.max_attempts;
    // A moving target's goal is where the target is at this trajectory's
    // own end; the insertion line is checked in the target's frame.
    const bool moving = MovesTheGoal(scene, *result);
    if (moving) {
      result->terminal = MovedState(result->terminal_at_zero, *scene.moving->motion, trajectory->duration());
      result->insertion = MovedInsertion(result->insertion_at_zero, *scene.moving->motion, trajectory->duration());
    }
    result->post_check = PostCheck(*trajectory, scene.robot, task, result->terminal,
                                   moving ? result->insertion_at_zero : result->insertion, collision, scene.exact,
                                   scene.self_collision, check, MovingPartOf(scene, *result));
    record.post_check_ms = MillisecondsSince(check_start);
    result->post_check_ms += record.post_check_ms;
    result->trajectory = std::move(*trajectory);
    if (auto breakdown = problem->Breakdown(x); breakdown.ok()) result->final_cost = *breakdown;
    record.post_check_failure = result->post_check.FirstFailure();
    result->attempts.push_back(record);
    if (result->post_check.passed) break;
    if (!RaiseWeightsOfFailedChecks(result->post_check, options.weight_raise_factor, options.resolve_sample_factor,
                                    options.max_samples_per_piece, &cost)) {
      break;
    }
    QUADHAND_RETURN_IF_ERROR(problem->SetOptions(cost));
  }
  result->success = result->post_check.passed;
  result->status = result->success ? PlanStatus::kSuccess : PlanStatus::kPostCheckFailed;
  result->message = result->success ? "plan passed the post-check" : result->post_check.FirstFailure();
  return core::Status::Ok();
}

double StateClearance(const PlanningScene& scene, const BoundaryState& state, const traj::FlatnessOptions& flatness,
                      double reach, int* link) {
  robot::KinematicsState kinematics;
  const traj::FlatState flat =
      traj::FlatForward(state.velocity, state.acceleration, state.jerk, state.yaw, state.yaw_rate, flatness);
  const Pose base = MakePose(state.position, flat.rotation());
  robot::ComputeKinematics(scene.robot, base, state.joints, &kinematics);
  return env::WholeBodyClearance(kinematics, scene.exact, reach, {}, link);
}

core::Result<bool> BuildPlanCollision(const PlanningScene& scene, const std::vector<Vec3>& path, const Vec3& start,
                                      const InitialGuess& guess, const Vec3& end, PlanCollision* collision,
                                      PlanResult* result) {
  collision->model = &scene.collision;
  collision->owned.reset();
  if (!scene.per_plan_collision) return true;
  std::vector<Vec3> boundaries = {start};
  for (int i = 0; i < guess.position_waypoints.cols(); ++i) boundaries.push_back(guess.position_waypoints.col(i));
  boundaries.push_back(end);
  auto built = scene.per_plan_collision(path.empty() ? boundaries : path, boundaries, &result->per_plan_collision_ms);
  if (!built.ok()) {
    if (built.status().code() != core::StatusCode::kInfeasible) return built.status();
    result->status = PlanStatus::kRepresentationFailed;
    result->message = built.status().message();
    return false;
  }
  collision->owned = std::move(*built);
  collision->model = collision->owned.get();
  return true;
}

core::Result<std::vector<WaypointBall>> ViaBalls(const std::vector<ViaPoint>& vias, const MatX& waypoints) {
  // The front end makes every via a corner, and the guess a waypoint on
  // every corner: the via's waypoint is the first one on it after the last
  // via's. (Nearest, not equal: a via on the start has no waypoint of its
  // own, and then the nearest one later is held near it.)
  std::vector<WaypointBall> balls;
  int previous = -1;
  const int count = static_cast<int>(waypoints.cols());
  for (size_t k = 0; k < vias.size(); ++k) {
    const int last = count - static_cast<int>(vias.size() - k);  // leave one for each via after this one
    int best = -1;
    double best_distance = std::numeric_limits<double>::infinity();
    for (int i = previous + 1; i <= last; ++i) {
      const double distance = (waypoints.col(i) - vias[k].position).norm();
      if (distance < best_distance) {
        best = i;
        best_distance = distance;
      }
    }
    if (best < 0) {
      return core::Status::InvalidArgument(core::Format("%zu vias need at least as many inner waypoints; the guess has %d",
                                                        vias.size(), count));
    }
    balls.push_back({best, vias[k].position, vias[k].tolerance});
    previous = best;
  }
  return balls;
}

core::Status Optimise(const PlanningScene& scene, const PlanCollision& collision, const Task& task,
                      const InitialGuess& guess, const PlannerOptions& options, const SolveSchedule& schedule,
                      PlanResult* result) {
  result->num_pieces = static_cast<int>(guess.durations.size());
  // A moving target: the optimiser gets the goal at t = 0 and moves it.
  const bool moving = MovesTheGoal(scene, *result);
  auto problem = WholeBodyProblem::Create(scene.robot, *collision.model, task.start,
                                          moving ? result->terminal_at_zero : result->terminal, task.limits,
                                          moving ? result->insertion_at_zero : result->insertion,
                                          CostForTask(options, task), result->num_pieces, scene.self_collision);
  if (!problem.ok()) return problem.status().WithPrefix(task.file);
  if (const MovingScene* part = MovingPartOf(scene, *result)) QUADHAND_RETURN_IF_ERROR((*problem)->SetMovingScene(part));
  if (!task.vias.empty()) {
    auto balls = ViaBalls(task.vias, guess.position_waypoints);
    if (!balls.ok()) return balls.status().WithPrefix(task.file);
    QUADHAND_RETURN_IF_ERROR((*problem)->SetWaypointBalls(std::move(*balls)));
  }
  const VecX x0 = (*problem)->Pack(guess.position_waypoints, guess.aux_waypoints, guess.durations);
  return SolveAndPostCheck(problem->get(), x0, scene, *collision.model, task, options, schedule, result);
}

namespace {

// Stage "resolve goal": the terminal state (given, or searched for a tool
// pose), its yaw the shortest way round from the start, and the insertion.
// False, with result->status kTerminalStateFailed, when no terminal state
// reaches the tool pose.
core::Result<bool> ResolveGoal(const PlanningScene& scene, const Task& task, const PlannerOptions& options,
                               const opt::Solver& solver, PlanResult* result) {
  const robot::RobotModel& robot = scene.robot;
  if (task.terminal) {
    result->terminal = *task.terminal;
  } else {
    const int tool_link = robot.LinkIndex(task.tool_link);
    if (tool_link < 0) {
      return core::Status::InvalidArgument(task.file + ": tool_link: the robot has no link named '" + task.tool_link + "'");
    }
    TerminalStateOptions search = options.terminal_state;
    search.clearance_tolerance = options.post_check.clearance_tolerance;
    auto found = FindTerminalState(robot, scene.collision, scene.exact, task, *task.tool, tool_link, search, solver);
    if (!found.ok()) {
      if (found.status().code() != core::StatusCode::kInfeasible) return found.status();
      result->status = PlanStatus::kTerminalStateFailed;
      result->message = found.status().message();
      return false;
    }
    result->terminal_searched = true;
    result->terminal_search = *found;
    result->terminal = found->state;
  }
  result->terminal.yaw = task.start.yaw + std::remainder(result->terminal.yaw - task.start.yaw, 2.0 * M_PI);

  InsertionGoal& insertion = result->insertion;
  if (task.tool && task.tool->has_insertion) {
    insertion = InsertionOf(*task.tool, robot.LinkIndex(task.tool_link));
    if (insertion.tool_link < 0) {
      return core::Status::InvalidArgument(task.file + ": tool_link: the robot has no link named '" + task.tool_link + "'");
    }
    // The terminal state must put the tool where the task says.
    const Pose tool = robot::LinkPose(robot, HoverPose(result->terminal.position, result->terminal.yaw),
                                      result->terminal.joints, insertion.tool_link);
    const double mismatch = (tool.translation() - insertion.tool_position).norm();
    if (mismatch > options.post_check.position_tolerance) {
      return core::Status::InvalidArgument(task.file + ": goal: the terminal state puts the tool " +
                                           std::to_string(mismatch) + " m from goal.tool.position");
    }
  }
  return true;
}

// Stage "check end points": start and goal must be collision-free, or no
// plan can pass the post-check. Under the post-check's recovery rule
// (PostCheckOptions::recovery_time) the start need only clear what that
// rule's stretch may not go below.
core::Status CheckEndPoints(const PlanningScene& scene, const Task& task, const BoundaryState& terminal,
                            const PlannerOptions& options) {
  const double reach = ClearanceSearchReach(task);
  const std::pair<const char*, const BoundaryState*> ends[] = {{"start", &task.start}, {"goal", &terminal}};
  const PostCheckOptions& check = options.post_check;
  for (const auto& [name, state] : ends) {
    int link = -1;
    const double clearance = StateClearance(scene, *state, options.cost.flatness, reach, &link);
    const bool recovering_start = state == &task.start && check.recovery_time > 0.0;
    const double accepted = recovering_start ? check.recovery_min_clearance - check.clearance_tolerance
                                             : AcceptedClearance(task, check.clearance_tolerance);
    if (clearance < accepted) {
      return core::Status::InvalidArgument(task.file + ": " + name + " state is in collision: link " +
                                           scene.robot.link(link).name + " is " + std::to_string(clearance) +
                                           " m from the scene (safety distance " +
                                           std::to_string(task.safety_distance) + " m)");
    }
  }
  return core::Status::Ok();
}

// Stage "front end": the base path to the start of the insertion (then
// straight along it), through the task's vias in order (one search per
// stretch; every via is a corner of the path, so the initial guess puts a
// waypoint on it). False, with result->status kFrontEndFailed, when the
// scene leaves no way.
core::Result<bool> FindFrontEndPath(const PlanningScene& scene, const Task& task, PlanResult* result) {
  const InsertionGoal& insertion = result->insertion;
  const auto front_start = std::chrono::steady_clock::now();
  const Vec3 approach_start = insertion.enabled
                                  ? Vec3(result->terminal.position - insertion.direction * insertion.length)
                                  : result->terminal.position;
  std::vector<Vec3> stops;
  for (const ViaPoint& via : task.vias) stops.push_back(via.position);
  stops.push_back(approach_start);
  FrontEndPath whole;
  Vec3 from = task.start.position;
  for (size_t k = 0; k < stops.size(); ++k) {
    auto path = scene.front_end.FindPath(from, stops[k]);
    if (!path.ok()) {
      result->front_end_ms = MillisecondsSince(front_start);
      const std::string stretch =
          stops.size() == 1 ? std::string()
          : k < task.vias.size()
              ? core::Format("to via %zu at (%.3f, %.3f, %.3f): ", k, stops[k].x(), stops[k].y(), stops[k].z())
              : std::string("from the last via to the goal: ");
      if (path.status().code() == core::StatusCode::kInfeasible) {
        result->status = PlanStatus::kFrontEndFailed;
        result->message = stretch + path.status().message();
        return false;
      }
      return path.status().WithPrefix(task.file);
    }
    const size_t skip = k == 0 ? 0 : 1;  // the via ends one stretch and starts the next
    whole.raw.insert(whole.raw.end(), path->raw.begin() + std::min(skip, path->raw.size()), path->raw.end());
    whole.shortcut.insert(whole.shortcut.end(), path->shortcut.begin() + std::min(skip, path->shortcut.size()),
                          path->shortcut.end());
    whole.expansions += path->expansions;
    whole.search_seconds += path->search_seconds;
    whole.shortcut_seconds += path->shortcut_seconds;
    whole.seconds += path->seconds;
    whole.start_escaped = whole.start_escaped || (k == 0 && path->start_escaped);
    whole.goal_escaped = path->goal_escaped;
    from = stops[k];
  }
  // A terminal where the start stands (a turn in place, an arm's motion
  // at a hover) is a path of one point, which the guess needs twice.
  if (whole.raw.size() == 1) whole.raw.push_back(whole.raw.front());
  if (whole.shortcut.size() == 1) whole.shortcut.push_back(whole.shortcut.front());
  result->front_end_ms = MillisecondsSince(front_start);
  result->path = std::move(whole);
  return true;
}

// Stage "initial guess": waypoints along the path's corners with a
// trapezoidal speed profile; yaw and joints linear in time, or (with
// stow_joints_in_transit) folded along the first leg and unfolded along the
// last (PlannerOptions).
core::Result<InitialGuess> GuessFromPath(const robot::RobotModel& robot, const Task& task,
                                         const PlannerOptions& options, const std::vector<Vec3>& corners,
                                         const PlanResult& result) {
  const InsertionGoal& insertion = result.insertion;
  const double cruise = std::min(options.cruise_speed, task.limits.v_max);
  const double acceleration = std::min(options.cruise_acceleration, task.limits.a_max);
  const int pieces = PieceCountForPath(corners, options.piece_length, options.min_pieces);
  InitialGuess guess;
  QUADHAND_RETURN_IF_ERROR(
      InitialGuessFromPath(corners, pieces, cruise, acceleration, &guess.position_waypoints, &guess.durations));
  // A guess too short to make its turn within the yaw rate limit (a turn
  // in place has no path to time it by) takes long enough to turn at two
  // thirds of the limit; a guess that can make it is left as it is.
  const double least_turn_s = std::abs(result.terminal.yaw - task.start.yaw) / task.limits.yaw_rate_max;
  if (std::isfinite(least_turn_s) && guess.durations.sum() > 0.0 && guess.durations.sum() < least_turn_s) {
    guess.durations *= 1.5 * least_turn_s / guess.durations.sum();
  }
  const VecX& durations = guess.durations;
  const int n = robot.num_actuated();
  MatX& aux_waypoints = guess.aux_waypoints;
  aux_waypoints.resize(1 + n, pieces - 1);
  VecX aux_start(1 + n), aux_end(1 + n);
  aux_start << task.start.yaw, task.start.joints;
  aux_end << result.terminal.yaw, result.terminal.joints;
  const double aux_time = durations.sum() - (insertion.enabled ? durations[pieces - 1] : 0.0);
  // Times of the path corners (where the stowed phase begins and ends).
  const std::vector<Vec3>& legs = result.path.shortcut;
  const bool stow = options.stow_joints_in_transit && legs.size() >= 4;
  double stow_begin = 0.0, stow_end = aux_time;
  VecX stowed = VecX::Zero(n);
  if (stow) {
    for (int q = 0; q < n; ++q) {
      const double lo = task.limits.joint_lower[q] + options.stow_margin;
      const double hi = task.limits.joint_upper[q] - options.stow_margin;
      stowed[q] = lo <= hi ? std::clamp(0.0, lo, hi) : 0.5 * (task.limits.joint_lower[q] + task.limits.joint_upper[q]);
    }
    const double length = PathLength(legs);
    // Settled `stow_lead` before the first corner (the first corner is
    // usually at the first obstacle the path squeezes past), or halfway
    // along a first leg shorter than twice that.
    const double first_leg = (legs[1] - legs[0]).norm();
    stow_begin = aux_time * std::max(0.5 * first_leg, first_leg - options.stow_lead) / length;
    stow_end = aux_time * (1.0 - (legs[legs.size() - 1] - legs[legs.size() - 2]).norm() / length);
  }
  double elapsed = 0.0;
  for (int i = 0; i < pieces - 1; ++i) {
    elapsed += durations[i];
    const double f = std::min(1.0, elapsed / aux_time);
    aux_waypoints.col(i) = (1.0 - f) * aux_start + f * aux_end;  // yaw and joints linear in time, as the paper
    if (!stow) continue;
    if (options.settle_yaw_in_transit) {  // yaw at its goal value from where the arm is stowed
      const double g = std::min(1.0, elapsed / stow_begin);
      aux_waypoints(0, i) = (1.0 - g) * task.start.yaw + g * result.terminal.yaw;
    }
    VecX joints;
    if (elapsed <= stow_begin) {
      const double g = elapsed / stow_begin;
      joints = (1.0 - g) * task.start.joints + g * stowed;
    } else if (elapsed < stow_end) {
      joints = stowed;
    } else {
      const double g = std::min(1.0, (elapsed - stow_end) / (aux_time - stow_end));
      joints = (1.0 - g) * stowed + g * result.terminal.joints;
    }
    aux_waypoints.block(1, i, n, 1) = joints;
  }
  return guess;
}

// Stages "initial guess", "plan collision" and "optimise" from the
// front-end path's corners: false, with result->status set, when the
// representation cannot be built for this guess.
// Stage "sections" (PlannerOptions::section_pieces): the guess's pieces
// taken a section at a time. Each section is optimised (with its own
// re-solves) from where the plan has got to over its pieces and a quarter
// as many more, to the guess's whole state there (the last section: to the
// goal, with the insertion); its first pieces are kept and the next
// section starts where they end, so every junction is a state the
// optimiser chose with room on both sides. The kept pieces are joined and
// post-checked whole. False, with result's status and message, when a
// section fails (the pieces kept before it are the plan, for the report).
core::Result<bool> SolveInSections(const PlanningScene& scene, const Task& task, const PlannerOptions& options,
                                   const SolveSchedule& schedule, const InitialGuess& guess, PlanResult* result) {
  const int pieces = static_cast<int>(guess.durations.size());
  const int keep = options.section_pieces, overlap = std::max(2, options.section_pieces / 4);
  auto whole_guess = TrajectoryThrough(task.start, result->terminal, guess.position_waypoints, guess.aux_waypoints,
                                       guess.durations, options.cost.flatness);
  if (!whole_guess.ok()) return whole_guess.status();
  // The guess's time at each piece boundary (at[k]: before piece k).
  std::vector<double> at(pieces + 1, 0.0);
  for (int k = 0; k < pieces; ++k) at[k + 1] = at[k] + guess.durations[k];
  std::optional<WholeBodyTrajectory> joined;
  BoundaryState from = task.start;
  result->sections = 0;
  for (int first = 0; first < pieces;) {
    // Solved over [first, reach), kept over [first, last); the rest in one
    // section once it is no longer than a section and its overlap.
    const bool final_section = pieces - first <= keep + overlap;
    int reach = final_section ? pieces : first + keep + overlap;
    const int last = final_section ? pieces : first + keep;
    if (!final_section) {
      // The section's end is held at the guess's state there: the guess's
      // arm may reach into an obstacle the path passes (the path clears the
      // base only). The nearest piece boundary within half the overlap
      // whose state clears the scene by the safety distance and 5 cm, else
      // the clearest of them.
      const double wanted = task.safety_distance + 0.05;
      double best = -std::numeric_limits<double>::infinity();
      int best_reach = reach;
      for (int step = 0; step <= overlap / 2; ++step) {
        for (int sign : {1, -1}) {
          const int r = reach + sign * step;
          if ((step == 0 && sign < 0) || r <= last || r >= pieces) continue;  // the nominal end once
          const double clearance =
              StateClearance(scene, whole_guess->Sample(at[r]).State(), options.cost.flatness, wanted + 0.01, nullptr);
          if (clearance > best) {
            best = clearance;
            best_reach = r;
          }
        }
        if (best >= wanted) break;
      }
      reach = best_reach;
    }
    const int count = reach - first;
    ++result->sections;
    Task section = task;
    section.start = from;
    PlanResult part;
    part.path = result->path;
    if (final_section) {
      part.terminal = result->terminal;
      part.insertion = result->insertion;
    } else {
      section.tool.reset();
      part.terminal = whole_guess->Sample(at[reach]).State();
      section.terminal = part.terminal;
    }
    InitialGuess piece_guess;
    piece_guess.position_waypoints = guess.position_waypoints.middleCols(first, count - 1);
    piece_guess.aux_waypoints = guess.aux_waypoints.middleCols(first, count - 1);
    piece_guess.durations = guess.durations.segment(first, count);
    PlanCollision collision{&scene.collision, nullptr};
    QUADHAND_RETURN_IF_ERROR(Optimise(scene, collision, section, piece_guess, options, schedule, &part));
    result->solve_ms += part.solve_ms;
    result->post_check_ms += part.post_check_ms;
    result->iterations += part.iterations;
    result->evaluations += part.evaluations;
    result->attempts.insert(result->attempts.end(), part.attempts.begin(), part.attempts.end());
    if (!part.success || !part.trajectory) {
      result->success = false;
      result->status = part.status;
      result->message = core::Format("section %d (pieces %d to %d of %d, from %.2f s of the initial guess): ",
                                     result->sections, first + 1, reach, pieces, at[first]) +
                        part.message;
      result->post_check = part.post_check;
      result->trajectory = std::move(joined);
      return false;
    }
    result->final_cost = part.final_cost;
    // The kept pieces, and the state where they end.
    std::optional<WholeBodyTrajectory> kept;
    if (final_section) {
      kept = std::move(part.trajectory);
    } else {
      auto prefix = TrajectoryPrefix(*part.trajectory, last - first);
      if (!prefix.ok()) return prefix.status();
      kept = std::move(*prefix);
      from = kept->Sample(kept->duration()).State();
    }
    if (joined) {
      auto both = JoinedTrajectory(*joined, *kept);
      if (!both.ok()) return both.status();
      joined = std::move(*both);
    } else {
      joined = std::move(kept);
    }
    first = last;
  }
  const auto check_start = std::chrono::steady_clock::now();
  result->post_check = PostCheck(*joined, scene.robot, task, result->terminal, result->insertion, scene.collision,
                                 scene.exact, scene.self_collision, options.post_check, nullptr);
  result->post_check_ms += MillisecondsSince(check_start);
  result->trajectory = std::move(joined);
  result->success = result->post_check.passed;
  result->status = result->success ? PlanStatus::kSuccess : PlanStatus::kPostCheckFailed;
  result->message = result->success ? "every section passed, and the joined plan passed the post-check"
                                     : "the joined sections failed the post-check: " + result->post_check.FirstFailure();
  return result->success;
}

core::Result<bool> SolveFromPath(const PlanningScene& scene, const Task& task, const PlannerOptions& options,
                                 const SolveSchedule& schedule, const std::vector<Vec3>& corners,
                                 PlanResult* result) {
  auto guess = GuessFromPath(scene.robot, task, options, corners, *result);
  if (!guess.ok()) return guess.status();
  result->num_pieces = static_cast<int>(guess->durations.size());
  const bool sectioned = options.section_pieces > 0 && result->num_pieces > options.section_pieces &&
                         !result->moving_target && scene.moving == nullptr && task.vias.empty() &&
                         scene.per_plan_collision == nullptr;
  if (sectioned) {
    auto solved = SolveInSections(scene, task, options, schedule, *guess, result);
    if (!solved.ok()) return solved.status();
    return true;  // solved or not, the result says
  }
  PlanCollision collision;
  auto built = BuildPlanCollision(scene, corners, task.start.position, *guess, result->terminal.position, &collision,
                                  result);
  if (!built.ok()) return built.status();
  if (!*built) return false;
  QUADHAND_RETURN_IF_ERROR(Optimise(scene, collision, task, *guess, options, schedule, result));
  return true;
}

// Stage "alternatives" (PlannerOptions::alternative_guesses): other initial
// guesses from the same front-end path, in a fixed order, while the plan has
// failed its post-check or its solver; the first that passes is kept. The
// times, counts and attempts of every try add up in the result.
core::Status TryAlternativeGuesses(const PlanningScene& scene, const Task& task, const PlannerOptions& options,
                                   const SolveSchedule& schedule, const std::vector<Vec3>& corners,
                                   PlanResult* result) {
  struct Alternative {
    const char* name;
    std::function<void(PlannerOptions*)> change;
  };
  const Alternative alternatives[] = {
      {"slower", [](PlannerOptions* o) { o->cruise_speed *= 0.6; }},
      {"arm", [](PlannerOptions* o) { o->stow_joints_in_transit = !o->stow_joints_in_transit; }},
      {"finer", [](PlannerOptions* o) { o->piece_length *= 0.5; }},
  };
  const int count = std::min<int>(options.alternative_guesses, static_cast<int>(std::size(alternatives)));
  for (int i = 0; i < count && !result->success; ++i) {
    if (result->status != PlanStatus::kPostCheckFailed && result->status != PlanStatus::kSolverFailed) break;
    PlannerOptions changed = options;
    alternatives[i].change(&changed);
    PlanResult trial;
    trial.terminal = result->terminal;
    trial.insertion = result->insertion;
    trial.moving_target = result->moving_target;
    trial.terminal_at_zero = result->terminal_at_zero;
    trial.insertion_at_zero = result->insertion_at_zero;
    trial.target_at_zero = result->target_at_zero;
    trial.path = result->path;
    auto solved = SolveFromPath(scene, task, changed, schedule, corners, &trial);
    if (!solved.ok()) return solved.status();
    ++result->alternatives_tried;
    result->per_plan_collision_ms += trial.per_plan_collision_ms;
    if (!*solved) continue;
    result->solve_ms += trial.solve_ms;
    result->post_check_ms += trial.post_check_ms;
    result->iterations += trial.iterations;
    result->evaluations += trial.evaluations;
    result->attempts.insert(result->attempts.end(), trial.attempts.begin(), trial.attempts.end());
    if (!trial.success) continue;
    result->success = true;
    result->status = trial.status;
    result->message = trial.message;
    result->trajectory = std::move(trial.trajectory);
    result->terminal = trial.terminal;
    result->insertion = trial.insertion;
    result->post_check = std::move(trial.post_check);
    result->final_cost = std::move(trial.final_cost);
    result->num_pieces = trial.num_pieces;
    result->sections = trial.sections;
    result->initial_guess = alternatives[i].name;
  }
  return core::Status::Ok();
}

// Stage "resolve a moving goal" (docs/moving_targets.md): the arrival time
// and the terminal state are found together. From a first guess of the
// arrival (the straight line to the target at cruise speed), each round
// searches the terminal state against the scene as it stands then (the
// still models and the moving ones where the points are then), finds the front-end path
// to it and the initial guess's duration; the next round aims at that
// duration, until the two agree within 5 % (at most kArrivalRounds). The
// optimiser then moves the arrival itself. Sets the terminal state and
// insertion at the arrival, the same at t = 0, and the path. False, with
// the status set, when no terminal state or path is found.
core::Result<bool> ResolveMovingGoal(const PlanningScene& scene, const Task& task, const PlannerOptions& options,
                                     const opt::Solver& solver, PlanResult* result) {
  constexpr int kArrivalRounds = 4;
  const MovingScene& moving = *scene.moving;
  const TargetMotion& motion = *moving.motion;
  const robot::RobotModel& robot = scene.robot;
  const int tool_link = robot.LinkIndex(task.tool_link);
  if (tool_link < 0) {
    return core::Status::InvalidArgument(task.file + ": tool_link: the robot has no link named '" + task.tool_link + "'");
  }
  // The start must clear the moving points where they start.
  if (moving.has_points()) {
    robot::KinematicsState kinematics;
    robot::ComputeKinematics(robot, HoverPose(task.start.position, task.start.yaw), task.start.joints, &kinematics);
    int link = -1;
    // (A mission's leg starts later on the target's clock: the points have moved.)
    const double clearance = env::WholeBodyClearance(InTargetFrameAtZero(kinematics, motion, 0.0), *moving.exact,
                                                     ClearanceSearchReach(task), {}, &link);
    if (clearance < AcceptedClearance(task, options.post_check.clearance_tolerance)) {
      return core::Status::InvalidArgument(task.file + ": start state is in collision: link " + robot.link(link).name +
                                           " is " + std::to_string(clearance) +
                                           " m from the moving points (safety distance " +
                                           std::to_string(task.safety_distance) + " m)");
    }
  }
  result->moving_target = true;
  const ToolGoal& tool_at_zero = *task.tool;
  const InsertionGoal insertion_at_zero = InsertionOf(tool_at_zero, tool_link);
  TerminalStateOptions search = options.terminal_state;
  search.clearance_tolerance = options.post_check.clearance_tolerance;
  const double cruise = std::min(options.cruise_speed, task.limits.v_max);
  double arrival = (motion.Center(0.0) - task.start.position).norm() / cruise;
  for (int round = 0; round < kArrivalRounds; ++round) {
    result->arrival_rounds = round + 1;
    // The scene as it stands at the arrival: the still models and the
    // moving points' models where the points are then.
    std::optional<SceneAtTimeModel> collision_at, exact_at;
    if (moving.collision != nullptr) collision_at.emplace(scene.collision, *moving.collision, motion, arrival);
    if (moving.exact != nullptr) exact_at.emplace(scene.exact, *moving.exact, motion, arrival);
    const env::CollisionModel& search_collision =
        collision_at ? static_cast<const env::CollisionModel&>(*collision_at) : scene.collision;
    const env::CollisionModel& search_exact =
        exact_at ? static_cast<const env::CollisionModel&>(*exact_at) : scene.exact;
    // The tool goal where the target is then, as its insertion moved there.
    result->insertion = MovedInsertion(insertion_at_zero, motion, arrival);
    ToolGoal tool = tool_at_zero;
    tool.moving.reset();
    tool.position = result->insertion.tool_position;
    tool.orientation = result->insertion.tool_orientation;
    tool.insertion_direction = result->insertion.direction;
    auto found = FindTerminalState(robot, search_collision, search_exact, task, tool, tool_link, search, solver);
    if (!found.ok()) {
      if (found.status().code() != core::StatusCode::kInfeasible) return found.status();
      result->status = PlanStatus::kTerminalStateFailed;
      result->message = core::Format("the target as it is at %.2f s: ", arrival) + found.status().message();
      return false;
    }
    result->terminal_searched = true;
    result->terminal_search = *found;
    result->terminal = found->state;
    result->terminal.yaw = task.start.yaw + std::remainder(result->terminal.yaw - task.start.yaw, 2.0 * M_PI);
    // Errors about the end state or the path there are about the target
    // where it is at the arrival: they say so, naming the file once.
    const std::string at_arrival =
        core::Format("goal.tool.motion: the target as it is at %.2f s (the arrival aimed at): ", arrival);
    auto about_arrival = [&](const core::Status& status) {
      std::string message = status.message();
      if (message.rfind(task.file + ": ", 0) == 0) message.erase(0, task.file.size() + 2);
      return core::Status::InvalidArgument(task.file + ": " + at_arrival + message);
    };
    // The end state where the front end cannot search: a target gone from
    // the planning space by the arrival aimed at. Unreachable when no time
    // at which v_max in a straight line could bring the vehicle there finds
    // it inside either; otherwise a faster approach than the guess's
    // cruise_speed might, which this planner does not try.
    const FrontEndMap& space = scene.front_end;
    auto outside = [&](const Vec3& p) {
      return (space.min_corner() - p).cwiseMax(p - space.max_corner()).cwiseMax(0.0).norm();
    };
    if (outside(result->terminal.position) > 0.0) {
      const BoundaryState at_zero = StateAtZero(result->terminal, motion, arrival);
      // Over the times the vehicle could be at the end state (v_max in a
      // straight line): the least distance outside, and when it is inside.
      double least = std::numeric_limits<double>::infinity(), least_at = 0.0, first = -1.0, last = -1.0;
      double earliest = -1.0, leaves = -1.0;  // the first such time; the last time it is inside at all
      const double horizon = std::max(2.0 * arrival, 60.0);
      for (double t = 0.0; t <= horizon; t += kReachStep) {
        const Vec3 end = MovedState(at_zero, motion, t).position;
        const double out = outside(end);
        if (out == 0.0) leaves = t;
        if ((end - task.start.position).norm() > task.limits.v_max * t) continue;  // not there by then
        if (earliest < 0.0) earliest = t;
        if (out < least) {
          least = out;
          least_at = t;
        }
        if (out == 0.0) {
          if (first < 0.0) first = t;
          last = t;
        }
      }
      if (first < 0.0) {
        result->status = PlanStatus::kTargetUnreachable;
        result->target_out_of_reach_m = std::isfinite(least) ? least : outside(result->terminal.position);
        result->target_out_of_reach_at_s = least_at;
        const std::string when = earliest < 0.0 ? core::Format("not within %.0f s", horizon)
                                                : core::Format("at %.2f s at the earliest", earliest);
        result->message = core::Format(
            "the target cannot be met within the limits: the vehicle's end state, moving with the target, %s the "
            "space searched (the front end's box)",
            leaves < 0.0 ? "is never inside" : core::Format("leaves at %.2f s", leaves).c_str()) +
            core::Format("; at v_max (%.2f m/s) the vehicle could be there %s; out of reach by %.3f m at %.2f s",
                         task.limits.v_max, when.c_str(), result->target_out_of_reach_m, least_at);
        return false;
      }
      result->status = PlanStatus::kFrontEndFailed;
      result->message = at_arrival + core::Format(
          "the vehicle's end state is %.3f m outside the space searched; the target is within reach only from "
          "%.2f to %.2f s, sooner than the approach at cruise_speed (%.2f m/s) gets there",
          outside(result->terminal.position), first, last, cruise);
      return false;
    }
    if (core::Status s = CheckEndPoints(scene, task, result->terminal, options); !s.ok()) return about_arrival(s);
    auto path = FindFrontEndPath(scene, task, result);
    if (!path.ok()) return about_arrival(path.status());
    if (!*path) {
      result->message = at_arrival + result->message;
      return false;
    }
    std::vector<Vec3> corners = result->path.shortcut;
    if (result->insertion.enabled) corners.push_back(result->terminal.position);
    auto guess = GuessFromPath(robot, task, options, corners, *result);
    if (!guess.ok()) return guess.status();
    const double guessed = guess->durations.sum();
    result->arrival_guess_s = arrival;
    if (std::abs(guessed - arrival) <= 0.05 * guessed) break;
    arrival = guessed;
  }
  result->terminal_at_zero = StateAtZero(result->terminal, motion, result->arrival_guess_s);
  result->insertion_at_zero = insertion_at_zero;
  result->target_at_zero = moving.target_at_zero;
  return true;
}

}  // namespace

core::Result<PlanResult> Plan(const PlanningScene& scene, const Task& task, const PlannerOptions& options,
                              const opt::Solver& solver) {
  if (std::string why; !options.IsValid(&why)) return core::Status::InvalidArgument("planner options: " + why);
  if (!PlansAsGoal(task)) {
    return core::Status::InvalidArgument(task.file + ": mission: " + std::to_string(task.mission.size()) +
                                         " step(s); only a goal or a mission of one reach plans here (PlanTask "
                                         "plans missions)");
  }
  if (!task.terminal && !task.tool) return core::Status::InvalidArgument(task.file + ": goal: no terminal state or tool pose");
  // A moving target planned as a still one would grasp where it was.
  if (task.tool && task.tool->moving && scene.moving == nullptr) {
    return core::Status::InvalidArgument(task.file + ": goal.tool.motion: this scene was built without the target's "
                                         "motion (PlanningContext builds it)");
  }
  PlanResult result;
  if (scene.moving != nullptr && task.tool && task.tool->moving) {
    auto resolved = ResolveMovingGoal(scene, task, options, solver, &result);
    if (!resolved.ok()) return resolved.status();
    if (!*resolved) return result;
  } else {
    auto resolved = ResolveGoal(scene, task, options, solver, &result);
    if (!resolved.ok()) return resolved.status();
    if (!*resolved) return result;
    QUADHAND_RETURN_IF_ERROR(CheckEndPoints(scene, task, result.terminal, options));
    auto found = FindFrontEndPath(scene, task, &result);
    if (!found.ok()) return found.status();
    if (!*found) return result;
  }
  std::vector<Vec3> corners = result.path.shortcut;
  if (result.insertion.enabled) corners.push_back(result.terminal.position);
  const SolveSchedule schedule{solver, options.solver, options.solver, options.max_attempts};
  auto solved = SolveFromPath(scene, task, options, schedule, corners, &result);
  if (!solved.ok()) return solved.status();
  if (!*solved) return result;
  QUADHAND_RETURN_IF_ERROR(TryAlternativeGuesses(scene, task, options, schedule, corners, &result));
  return result;
}

}  // namespace quadhand::planner

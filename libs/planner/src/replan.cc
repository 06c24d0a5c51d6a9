#include "quadhand/planner/replan.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <optional>

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
  if (!(std::isfinite(horizon) && horizon >= 0.0)) {
    if (why != nullptr) *why = "replan horizon must be finite and non-negative (0: never rejoin)";
    return false;
  }
  if (horizon_attempts < 1) {
    if (why != nullptr) *why = "replan horizon_attempts must be at least 1";
    return false;
  }
  if (!(std::isfinite(max_rejoin_stretch) && max_rejoin_stretch >= 1.0)) {
    if (why != nullptr) *why = "replan max_rejoin_stretch must be finite and at least 1";
    return false;
  }
  if (max_rejoin_tries < 1) {
    if (why != nullptr) *why = "replan max_rejoin_tries must be at least 1";
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
  while (first_duration < min_piece_duration && last + 1 < N) {
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


namespace {

// Where a replan rejoins the current plan (replan.h): the new part is the
// first `new_pieces` pieces of the remainder guess and ends at the end of
// the current plan's piece `junction_piece`, at `old_time` on its clock, in
// its full state there.
struct Rejoin {
  int junction_piece = -1;
  int new_pieces = 0;
  double old_time = 0.0;
  BoundaryState state;
};

// The rejoin point for `guess` (the remainder from t_from): its first
// junction at least `horizon` ahead and at least `min_new_pieces` pieces
// on, else its last junction. Nothing when rejoining is off, no such
// junction is left (the remainder is a single piece), or the current plan's
// certificate does not carry the rest at the full safety distance.
std::optional<Rejoin> FindRejoin(const PlanResult& current, const Task& task, const PostCheckOptions& check,
                                 const VecX& guess_durations, double t_from, double horizon, int min_new_pieces) {
  if (horizon <= 0.0 || !current.success || !current.trajectory) return std::nullopt;
  const WholeBodyTrajectory& trajectory = *current.trajectory;
  const int old_pieces = trajectory.num_pieces();
  const int remaining = static_cast<int>(guess_durations.size());
  const int last_merged = old_pieces - remaining;  // old piece ending the guess's first piece
  Rejoin rejoin;
  double planned = 0.0;
  for (int k = 1; k < remaining; ++k) {  // k < remaining: at least one piece is kept
    planned += guess_durations[k - 1];
    if ((planned >= horizon && k >= min_new_pieces) || k == remaining - 1) {
      rejoin.new_pieces = k;
      rejoin.junction_piece = last_merged + k - 1;
      break;
    }
  }
  if (rejoin.new_pieces < std::max(1, min_new_pieces)) return std::nullopt;
  rejoin.old_time = t_from + planned;
  const std::vector<CertifiedInterval>& intervals = current.post_check.certified_intervals;
  if (intervals.empty() || intervals.back().t1 < trajectory.duration() - 1e-9) return std::nullopt;
  const double clearance_bound = AcceptedClearance(task, check.clearance_tolerance);
  const double self_bound = AcceptedSelfClearance(task, check.clearance_tolerance);
  for (const CertifiedInterval& interval : intervals) {
    if (interval.t1 <= rejoin.old_time) continue;
    if (interval.clearance_lower < clearance_bound || interval.self_distance_lower < self_bound) return std::nullopt;
  }
  const traj::Minco& position = trajectory.position();
  const traj::Minco& aux = trajectory.aux();
  const int j = rejoin.junction_piece;
  const double end = position.durations()[j];
  rejoin.state.position = position.Evaluate(j, end, 0);
  rejoin.state.velocity = position.Evaluate(j, end, 1);
  rejoin.state.acceleration = position.Evaluate(j, end, 2);
  rejoin.state.jerk = position.Evaluate(j, end, 3);
  const VecX value = aux.Evaluate(j, end, 0), rate = aux.Evaluate(j, end, 1);
  rejoin.state.yaw = value[0];
  rejoin.state.yaw_rate = rate[0];
  rejoin.state.joints = value.tail(value.size() - 1);
  rejoin.state.joint_rates = rate.tail(rate.size() - 1);
  return rejoin;
}

// The report of a rejoined plan: the new part's checks, and for the kept
// pieces (from new_time on, old_time on the current plan's clock) the
// current plan's certificate, end-state and insertion checks, shifted to
// the new clock. Figures are the least of both parts.
PostCheckReport RejoinedReport(const PostCheckReport& part, const PostCheckReport& kept, double old_time,
                               double new_time, double safety_distance) {
  PostCheckReport report = part;
  const double shift = new_time - old_time;
  double kept_lower = 1e300, kept_lower_time = 0.0, kept_self = 1e300, kept_self_time = 0.0;
  double kept_sampled = 1e300;
  for (const CertifiedInterval& interval : kept.certified_intervals) {
    if (interval.t1 <= old_time) continue;
    CertifiedInterval moved = interval;
    if (moved.t0 < old_time) {  // cut at the rejoin point: its bound still holds on the rest
      moved.t0 = old_time;
      moved.clearance_sampled = interval.clearance_at_t1;
    }
    kept_sampled = std::min(kept_sampled, moved.clearance_sampled);
    moved.t0 += shift;
    moved.t1 += shift;
    if (moved.clearance_lower < kept_lower) {
      kept_lower = moved.clearance_lower;
      kept_lower_time = moved.t0;
    }
    if (moved.self_distance_lower < kept_self) {
      kept_self = moved.self_distance_lower;
      kept_self_time = moved.t0;
    }
    report.certified_intervals.push_back(moved);
  }
  if (kept_sampled < report.min_clearance_exact) {
    report.min_clearance_exact = kept_sampled;
    report.closest_link = -1;  // the kept stretches do not record their link
  }
  char note[160];
  std::snprintf(note, sizeof(note), "; kept from t = %.3f s (the current plan, certified): least %.4f m", new_time,
                kept_lower);
  for (CheckResult& check : report.checks) {
    if (check.kind == CheckKind::kClearance) {
      if (kept_lower < check.value) {
        check.value = kept_lower;
        check.time = kept_lower_time;
      }
      check.detail += note;
    } else if (check.kind == CheckKind::kSelfClearance && kept_self < check.value) {
      check.value = kept_self;
      check.time = kept_self_time;
    }
  }
  report.certified_clearance = std::min(report.certified_clearance, kept_lower);
  report.certified_margin = std::min(report.certified_margin, kept_lower - safety_distance);
  report.certified_self_distance = std::min(report.certified_self_distance, kept_self);
  // The new part ends at the rejoin state (its own end-state check, kept
  // when it fails); the plan's real end and insertion are the kept ones.
  for (const CheckResult& old_check : kept.checks) {
    if (old_check.kind != CheckKind::kEndState && old_check.kind != CheckKind::kInsertion) continue;
    CheckResult moved = old_check;
    moved.time += shift;
    auto same = std::find_if(report.checks.begin(), report.checks.end(),
                             [&](const CheckResult& c) { return c.kind == old_check.kind; });
    if (same == report.checks.end()) {
      report.checks.push_back(moved);
    } else if (same->passed) {
      *same = moved;
    }
  }
  for (auto& [name, ratio] : report.violations) {
    for (const auto& [old_name, old_ratio] : kept.violations) {
      if (old_name == name) ratio = std::max(ratio, old_ratio);
    }
  }
  report.passed = true;
  for (const CheckResult& check : report.checks) report.passed = report.passed && check.passed;
  report.certified = report.certified && report.passed;
  return report;
}

// Solves and checks the new part up to `rejoin` and joins the kept pieces to
// it. True with `result` a successful plan, false with `result` the failed
// new part's figures (times, attempts) for the fallback to add.
core::Result<bool> SolveRejoining(const PlanningScene& scene, const Task& task, const PlannerOptions& options,
                                  const ReplanOptions& replan, const opt::Solver& solver, const PlanResult& current,
                                  const InitialGuess& remainder, const Rejoin& rejoin, PlanResult* result) {
  InitialGuess guess;
  const int k = rejoin.new_pieces;
  guess.durations = remainder.durations.head(k);
  guess.position_waypoints = remainder.position_waypoints.leftCols(k - 1);
  guess.aux_waypoints = remainder.aux_waypoints.leftCols(k - 1);
  PlanResult part;
  part.terminal = rejoin.state;
  part.insertion = InsertionGoal{};  // the insertion lies in the kept pieces
  PlanCollision collision;
  auto built = BuildPlanCollision(scene, {}, task.start.position, guess, rejoin.state.position, &collision, &part);
  if (!built.ok()) return built.status();
  if (*built) {
    const SolveSchedule schedule{solver, replan.solver, options.solver,
                                 std::min(replan.horizon_attempts, replan.max_attempts)};
    QUADHAND_RETURN_IF_ERROR(Optimise(scene, collision, task, guess, options, schedule, &part));
  }
  result->solve_ms += part.solve_ms;
  result->post_check_ms += part.post_check_ms;
  result->per_plan_collision_ms += part.per_plan_collision_ms;
  result->iterations += part.iterations;
  result->evaluations += part.evaluations;
  result->attempts.insert(result->attempts.end(), part.attempts.begin(), part.attempts.end());
  if (!part.success) return false;
  // A new part far slower than the current plan's way to the same junction
  // is a detour: past (or too close to) the junction, the fixed rejoin
  // state's velocity can only be met by flying on, turning and coming back.
  // Such a plan is certified, but it crosses the obstacles near the junction
  // twice more, and every crossing risks the tracking error there.
  if (part.trajectory->duration() > replan.DetourLimit(guess.durations.sum())) {
    result->rejoin_refused_as_detour = true;
    return false;
  }
  const WholeBodyTrajectory& kept = *current.trajectory;
  auto position = traj::Minco::Joined(part.trajectory->position(), kept.position(), rejoin.junction_piece + 1);
  if (!position.ok()) return position.status();
  auto aux = traj::Minco::Joined(part.trajectory->aux(), kept.aux(), rejoin.junction_piece + 1);
  if (!aux.ok()) return aux.status();
  const double new_time = part.trajectory->duration();
  result->trajectory.emplace(std::move(*position), std::move(*aux), kept.flatness());
  result->post_check = RejoinedReport(part.post_check, current.post_check, rejoin.old_time, new_time,
                                      task.safety_distance);
  result->final_cost = part.final_cost;
  result->num_pieces = result->trajectory->num_pieces();
  result->rejoined_at = new_time;
  result->success = result->post_check.passed;
  result->status = result->success ? PlanStatus::kSuccess : PlanStatus::kPostCheckFailed;
  result->message = result->success ? "plan passed the post-check (the current plan is rejoined at t = " +
                                          std::to_string(new_time) + " s)"
                                    : result->post_check.FirstFailure();
  return result->success;
}

}  // namespace

core::Result<PlanResult> Replan(const PlanningScene& scene, const Task& task, const PlannerOptions& options,
                                const ReplanOptions& replan, const opt::Solver& solver, const PlanResult& current,
                                double t_from, const BoundaryState& start) {
  if (std::string why; !options.IsValid(&why)) return core::Status::InvalidArgument("planner options: " + why);
  if (std::string why; !replan.IsValid(&why)) return core::Status::InvalidArgument(why);
  if (!current.trajectory) return core::Status::InvalidArgument("replanning needs a current trajectory");
  // Which vias a replan from the middle still has to pass is not known here
  // (missions are not replanned in flight: docs/online.md).
  if (!task.vias.empty()) return core::Status::InvalidArgument("a plan through vias is not replanned");
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
  // A moving target: `scene.moving` is the new prediction, its clock
  // starting at the new plan's start. The grasp (the terminal state and the
  // insertion relative to the target) is carried from the current plan's
  // target at its zero to the new one's: a rigid move with a turn about z,
  // which a hovering state follows exactly.
  const bool moving = current.moving_target;
  if (moving) {
    if (scene.moving == nullptr || !scene.moving->moves()) {
      return core::Status::InvalidArgument("a plan to a moving target is replanned against a prediction of it "
                                           "(PlanningScene::moving)");
    }
    const Pose carry = scene.moving->target_at_zero * current.target_at_zero.inverse();
    const double turn = std::atan2(carry.linear()(1, 0), carry.linear()(0, 0));
    result.moving_target = true;
    result.target_at_zero = scene.moving->target_at_zero;
    result.terminal_at_zero = MovedRestState(current.terminal_at_zero, carry, turn);
    result.insertion_at_zero = MovedInsertion(current.insertion_at_zero, carry);
  }

  InitialGuess guess;
  int first_piece = 0;
  QUADHAND_RETURN_IF_ERROR(RemainderGuess(trajectory, t_from, replan.min_piece_duration, &guess.position_waypoints,
                                          &guess.aux_waypoints, &guess.durations, &first_piece));
  const int old_pieces = trajectory.num_pieces();
  if (current.insertion.enabled) {
    // The insertion piece must start backed off the full length above the
    // goal; a start inside it, or too close before it to keep a proper first
    // piece, cannot give a plan that passes the insertion check. A moving
    // target's goal moves on, though: a start inside the piece is replanned
    // as the rest of an approach that has begun (InsertionGoal::begun),
    // along the line in the target's frame, while at least
    // min_piece_duration of it is left.
    const bool inside = first_piece == old_pieces - 1;
    const bool merged_into_insertion = guess.durations.size() == 1;
    const double left = trajectory.duration() - t_from;
    if (moving && inside && left >= replan.min_piece_duration) {
      result.insertion_at_zero.begun = true;
      // Two pieces with a junction on the current plan halfway: one piece's
      // only freedom would be its duration.
      if (left >= 2.0 * replan.min_piece_duration) {
        const double half = 0.5 * left;
        const WholeBodySample mid = trajectory.Sample(t_from + half);
        guess.durations = VecX::Constant(2, half);
        guess.position_waypoints = mid.position;
        guess.aux_waypoints.resize(1 + n, 1);
        guess.aux_waypoints(0, 0) = mid.yaw;
        guess.aux_waypoints.block(1, 0, n, 1) = mid.joints;
      }
    } else if (inside || merged_into_insertion) {
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
    const double clearance = StateClearance(scene, replan_task.start, options.cost.flatness, ClearanceSearchReach(task),
                                            &link);
    if (clearance < -replan.max_start_penetration) {
      result.status = PlanStatus::kStartInCollision;
      result.message = "the start state is " + std::to_string(clearance) + " m from the scene (link " +
                       (link >= 0 ? robot.link(link).name : std::string("?")) + ", at most " +
                       std::to_string(replan.max_start_penetration) + " m inside it is recovered from)";
      return result;
    }
  }

  // The post-check of Plan() plus the recovery rule, which changes nothing
  // for a start outside the safety margin.
  PlannerOptions checked = options;
  checked.post_check.recovery_time = replan.recovery_time;
  checked.post_check.recovery_min_clearance = -replan.max_start_penetration;
  // Re-solves of a replan raise weights only; they keep the sample count
  // (measured with that rule: docs/online.md).
  checked.resolve_sample_factor = 1;

  // A moving goal moves the whole remainder's end: nothing of the current
  // plan can be kept. A part refused as a detour is tried again to a later
  // junction (more pieces to absorb the offset), up to max_rejoin_tries
  // times; a part that fails its checks, or the last try, falls back to the
  // whole remainder.
  int min_new_pieces = 1;
  for (int tries = 0; !moving && tries < replan.max_rejoin_tries; ++tries) {
    const auto rejoin =
        FindRejoin(current, task, checked.post_check, guess.durations, t_from, replan.horizon, min_new_pieces);
    if (!rejoin) break;
    auto rejoined = SolveRejoining(scene, replan_task, checked, replan, solver, current, guess, *rejoin, &result);
    if (!rejoined.ok()) return rejoined.status();
    if (*rejoined) return result;
    result.trajectory.reset();
    result.post_check = PostCheckReport{};
    if (!result.rejoin_refused_as_detour) break;
    min_new_pieces = rejoin->new_pieces + 1;
  }

  result.num_pieces = static_cast<int>(guess.durations.size());
  // Corridors (sfc) along the remaining piece boundaries: there is no front-end path.
  PlanCollision collision;
  const Vec3 end = moving ? MovedState(result.terminal_at_zero, *scene.moving->motion, guess.durations.sum()).position
                          : result.terminal.position;
  auto built = BuildPlanCollision(scene, {}, replan_task.start.position, guess, end, &collision, &result);
  if (!built.ok()) return built.status();
  if (!*built) return result;
  const SolveSchedule schedule{solver, replan.solver, options.solver, replan.max_attempts};
  QUADHAND_RETURN_IF_ERROR(Optimise(scene, collision, replan_task, guess, checked, schedule, &result));
  return result;
}

}  // namespace quadhand::planner

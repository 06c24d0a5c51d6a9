// The planning pipeline behind quadhand-plan: front-end path -> initial MINCO
// guess (yaw and joints interpolated in time, as the paper) -> whole-body
// optimisation with any opt::Solver -> post-check; when the post-check fails,
// the weights of the violated terms are raised and the solve is resumed from
// where it stopped (each attempt is reported).
#pragma once

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "quadhand/core/status.h"
#include "quadhand/env/collision_model.h"
#include "quadhand/opt/solver.h"
#include "quadhand/planner/front_end.h"
#include "quadhand/planner/moving_scene.h"
#include "quadhand/planner/plan_status.h"
#include "quadhand/planner/post_check.h"
#include "quadhand/planner/task.h"
#include "quadhand/planner/terminal_state.h"
#include "quadhand/planner/whole_body_problem.h"

namespace quadhand::planner {

// How the steps of a mission other than `reach` are made and checked
// (PlanTask(), docs/missions.md).
struct MissionPlanOptions {
  // A held object's SDF, made in memory at each grasp for the optimiser
  // (the checks use its exact shape): node spacing and margin, metres.
  double object_sdf_resolution = 0.004;
  double object_sdf_padding = 0.06;
  // A released object joins the scene as points this far apart on its surface.
  double released_surface_spacing = 0.005;
  // A move's top speed when its step gives no max_speed (also capped by
  // v_max), m/s, and its shortest duration, s.
  double move_speed = 0.25;
  double move_min_duration = 0.5;

  bool IsValid(std::string* why) const;
};

struct PlannerOptions {
  WholeBodyCostOptions cost;
  opt::SolverOptions solver;  // defaults set by DefaultPlannerOptions()
  PostCheckOptions post_check;
  TerminalStateOptions terminal_state;  // for goals given only as a tool pose
  MissionPlanOptions mission;
  // The optimiser penalises distances below safety distance + this margin, so
  // that SDF interpolation (< 1 mm) and sampling between cost samples do not
  // eat into the safety distance the post-check demands.
  double collision_margin = 0.01;
  // The same margin over the insertion piece (WholeBodyCostOptions::
  // insertion_collision_threshold): small, because there the robot moves
  // slowly and the gripper is meant to come close to the target.
  double insertion_collision_margin = 0.003;
  // The self-collision penalty starts at the task's self_safety_distance
  // plus this margin (the post-check bound is certified; the penalty's
  // samples are coarser and its SDFs interpolated).
  double self_collision_margin = 0.01;
  double piece_length = 0.4;    // metres of front-end path per MINCO piece
  int min_pieces = 4;
  // The initial time allocation (trapezoidal speed profile along the path):
  // starting near the optimal duration saves the slow redistribution of time
  // between pieces (docs/benchmark.md, "Tuning history").
  double cruise_speed = 0.7;    // m/s (capped by v_max)
  double cruise_acceleration = 0.7;  // m/s^2 (capped by a_max)
  // Initial guess of the joints. The paper interpolates them linearly in time
  // from start to goal; with `stow_joints_in_transit` they instead move to the
  // stowed configuration (each joint at the value within its limits closest
  // to zero, plus `stow_margin` from a limit: QuadHand's arm then points
  // straight forward, flat enough for the benchmark windows) along the first
  // leg of the front-end path, keep it through the corners, and reach the
  // goal configuration along the last leg before the insertion. Used only
  // when the path has at least three legs.
  bool stow_joints_in_transit = true;
  double stow_margin = 0.05;
  // With the joints stowed in transit, the initial yaw also reaches its goal
  // value along the first leg and keeps it through the corners (instead of
  // turning linearly in time over the whole trajectory), so that the arm
  // crosses narrow passages at a steady heading rather than while sweeping.
  bool settle_yaw_in_transit = true;
  // The stowing (and the yaw) is complete this many metres before the end
  // of the first leg (at half the leg if it is shorter than twice that):
  // the first corner is usually where the path squeezes past the first
  // obstacle, too late to still be folding the arm.
  double stow_lead = 0.5;
  int max_attempts = 4;         // solves per plan (the first plus re-solves with raised weights)
  // When every solve from the front end's guess fails its post-check (or
  // the solver fails), other initial guesses are tried in this fixed order,
  // each with the same solves, and the first that passes is kept: "slower"
  // (cruise_speed x 0.6: another time allocation), "arm" (the arm moved
  // the other way: stow_joints_in_transit toggled), "finer" (piece_length x
  // 0.5: more waypoints). At most this many (0..3; 0 = none).
  int alternative_guesses = 3;
  // A path of more pieces than this (0: never) is optimised a section at a
  // time: this many pieces kept from a solve over them and a quarter as
  // many more (to the initial guess's state there), the next section from
  // where they end; the sections are joined and post-checked whole. One
  // solve of a few hundred pieces stops at the cost's relative tolerance
  // while a local collision is still a small part of the cost
  // (docs/plan.md, "Long paths"). Not for a moving target, vias, or a
  // representation built per plan.
  int section_pieces = 120;
  double weight_raise_factor = 5.0;
  // A failed clearance check also multiplies the samples per piece of the
  // re-solve (and those of the insertion piece) by this, up to
  // max_samples_per_piece: a thin link can pass an obstacle edge between two
  // samples of a long piece, where no weight on the sampled penalty sees it.
  int resolve_sample_factor = 2;
  int max_samples_per_piece = 64;

  bool IsValid(std::string* why) const;
};

PlannerOptions DefaultPlannerOptions();

struct PlanAttempt {
  double solve_ms = 0;
  double post_check_ms = 0;  // 0 when the solver gave no trajectory to check
  int iterations = 0;
  int evaluations = 0;
  opt::SolveStatus solver_status = opt::SolveStatus::kInvalidInput;
  std::string post_check_failure;  // what failed, for people; empty when it passed
};

// One mission step's outcome (contracts.md 0.3: the report's `steps`).
struct StepResult {
  StepKind kind = StepKind::kReach;
  double start_s = 0.0, end_s = 0.0;
  // The least exact clearance of the robot (without the object it holds)
  // over the step, and whether it is only the search reach (nothing nearer).
  double min_clearance = 0.0;
  bool min_clearance_is_bound = false;
  // The held object's least exact clearance over the step, sampled (its
  // check is certified); none while nothing is held.
  std::optional<double> held_object_min_clearance;
  bool held_object_min_clearance_is_bound = false;  // as min_clearance_is_bound
  bool certified = false;  // every check of the step passed, clearances certified
  bool planned = false;    // false for the steps after the one that failed
};

// What each leg of a planned mission is judged against (PlanTask; the
// online mode judges a flown mission with it): the leg's plan times, its
// phase's robot (with the held object as its last link), the exact model of
// that robot without the object and of the object alone (null while nothing
// is held) on the phase's scene, and the clearance the object must keep.
// Valid while the result (which keeps the phases) and the planning context
// live.
struct MissionLeg {
  double start_s = 0.0, end_s = 0.0;
  size_t step = 0;
  const robot::RobotModel* robot = nullptr;
  const env::ExactMeshModel* robot_exact = nullptr;
  const env::ExactMeshModel* object_exact = nullptr;
  double object_clearance = 0.0;  // the safety distance, or 0 next to a grasp or release
  // The grasp step of the object held (its world pose is in the task), and
  // the object's link in `robot` (its last); -1 while nothing is held.
  long held_grasp_step = -1;
  int object_link = -1;
};

struct PlanResult {
  bool success = false;
  PlanStatus status = PlanStatus::kSolverFailed;
  std::string message;
  std::optional<WholeBodyTrajectory> trajectory;
  PostCheckReport post_check;
  BoundaryState terminal;   // the terminal state planned to (yaw unwrapped)
  bool terminal_searched = false;  // found by FindTerminalState (goal was a tool pose only)
  TerminalStateResult terminal_search;
  InsertionGoal insertion;  // the insertion enforced (enabled or not)
  // A moving target (docs/moving_targets.md): `terminal` and `insertion`
  // are then where the plan meets the target at its own duration; here they
  // are at t = 0 (the optimiser moves them with the target), with the
  // arrival time the initial guess aimed at and how many times the goal was
  // searched for on the way to it.
  bool moving_target = false;
  BoundaryState terminal_at_zero;
  InsertionGoal insertion_at_zero;
  Pose target_at_zero = Pose::Identity();  // the target's (tool goal's) pose at t = 0
  double arrival_guess_s = 0.0;
  int arrival_rounds = 0;
  // A longer mission's moving reach (negative: none, or not planned): when
  // the plan meets the target (s from its start), and the insertion there
  // (a goal's are its end and `insertion`).
  double target_met_s = -1.0;
  // How many sections the plan was optimised in (PlannerOptions::
  // section_pieces; 0: one solve over every piece).
  int sections = 0;
  InsertionGoal target_met_insertion;
  // With kTargetUnreachable: how far (m) the vehicle's end state, moved
  // with the target, is outside the space searched at the best time it
  // could be there; and that time (s).
  double target_out_of_reach_m = 0.0;
  double target_out_of_reach_at_s = 0.0;
  FrontEndPath path;
  CostBreakdown final_cost;
  std::vector<PlanAttempt> attempts;
  double front_end_ms = 0;
  double per_plan_collision_ms = 0;  // building a per-plan representation (corridors)
  double solve_ms = 0;  // optimisation wall time, all attempts
  double post_check_ms = 0;  // post-check wall time, all attempts
  int iterations = 0;
  int evaluations = 0;
  int num_pieces = 0;
  // The initial guess the plan came from: "front_end", or an alternative
  // (PlannerOptions::alternative_guesses), and how many were tried.
  std::string initial_guess = "front_end";
  int alternatives_tried = 0;
  // A replan that rejoined the current plan (replan.h): the time from which
  // the trajectory is the current plan's unchanged pieces; negative when the
  // whole trajectory is new.
  double rejoined_at = -1.0;
  // A replan with a certified rejoining part refused as a detour
  // (ReplanOptions::max_rejoin_stretch); it rejoined at a later junction
  // (rejoined_at >= 0) or replanned the whole remainder.
  bool rejoin_refused_as_detour = false;
  // A task with a mission: one entry per step, in order (PlanTask()), and
  // the time spent making each phase's scene after a grasp or a release
  // (its representations, front-end map and the held object's SDF).
  std::vector<StepResult> steps;
  double mission_phase_ms = 0;
  // A mission's legs in time order, and what keeps their models alive.
  std::vector<MissionLeg> mission_legs;
  std::vector<std::shared_ptr<const void>> mission_phases;
};

// Builds a collision model for one plan from the front-end path (its corner
// points) and the initial piece boundaries (start, waypoints, goal): for
// representations that depend on the path, such as safe-flight corridors.
// Writes the build time in milliseconds.
using PerPlanCollisionBuilder = std::function<core::Result<std::unique_ptr<env::CollisionModel>>(
    const std::vector<Vec3>& path, const std::vector<Vec3>& piece_boundaries, double* build_ms)>;

// What a plan needs besides the task: built once per scene and reused.
struct PlanningScene {
  const robot::RobotModel& robot;
  // The representation optimised against, and the one the terminal-state
  // search uses; with `per_plan_collision` set, only the latter.
  const env::CollisionModel& collision;
  const env::ExactMeshModel& exact;      // for the post-check
  const FrontEndMap& front_end;
  PerPlanCollisionBuilder per_plan_collision = nullptr;
  // The robot's link pairs the post-check keeps apart; null: none.
  const env::SelfCollisionModel* self_collision = nullptr;
  // A moving target and the points that move with it (moving_scene.h); the
  // models above then hold only the still points. Null: nothing moves.
  const MovingScene* moving = nullptr;
};

// Exact clearance (link meshes vs the scene's points) of `state`, searching
// `reach` metres; `link` (optional) gets the closest link. The base's
// attitude is the one its trajectory would start with (differential
// flatness of its velocity, acceleration, jerk and yaw): level only when it
// does not accelerate. A check at a level attitude would judge a braking or
// turning vehicle at a pose it is not in, and disagree with the
// post-check's first sample. Plan() checks its end points with it.
double StateClearance(const PlanningScene& scene, const BoundaryState& state, const traj::FlatnessOptions& flatness,
                      double reach, int* link = nullptr);

// The cost options a plan for `task` is optimised with: options.cost with the
// collision thresholds set from the task's safety distance plus
// options.collision_margin (transit) and options.insertion_collision_margin
// (insertion piece). Plan() and Replan() both use it.
WholeBodyCostOptions CostForTask(const PlannerOptions& options, const Task& task);

// Runs solves of `problem` from `x0` (at most `max_attempts`), each followed by
// the post-check against `task` (whose start is the problem's start state),
// raising the weights of the violated terms between solves (and, after a
// failed clearance check, the samples per piece by
// options.resolve_sample_factor up to options.max_samples_per_piece). The
// first solve uses schedule.first, the re-solves schedule.retry. Fills the
// trajectory, post_check, final_cost, attempts, solve_ms, iterations,
// evaluations, success, status (kSuccess, kPostCheckFailed,
// kSolverFailed) and message of *result; reads result->terminal and
// result->insertion. Errors only for inconsistent input (sizes, options).
// How a plan is solved: the back-end, the first solve's options, the
// re-solves' (after a failed post-check raised the weights), and how many
// solves at most. Plan uses PlannerOptions::solver for both; Replan starts
// with its own budget (ReplanOptions::solver).
struct SolveSchedule {
  const opt::Solver& solver;
  opt::SolverOptions first;
  opt::SolverOptions retry;
  int max_attempts = 1;
};

core::Status SolveAndPostCheck(WholeBodyProblem* problem, const VecX& x0, const PlanningScene& scene,
                               const env::CollisionModel& collision, const Task& task,
                               const PlannerOptions& options, const SolveSchedule& schedule, PlanResult* result);

// Raises (by `factor`, once however many terms share it or failed checks
// name it) the weight of each term whose post-check failed; a failed clearance also multiplies the samples per piece by `sample_factor`
// (up to `max_samples`): a link that slips past an obstacle between two
// samples is invisible to the sampled penalty, whatever its weight. False when
// no failed check has a weight to raise (re-solving cannot help).
bool RaiseWeightsOfFailedChecks(const PostCheckReport& report, double factor, int sample_factor, int max_samples,
                                WholeBodyCostOptions* cost);

// InvalidArgument for inconsistent input (e.g. a start in collision, or a
// goal the front end cannot reach from inside the scene box); otherwise a
// PlanResult whose `success` says whether the post-check passed.
core::Result<PlanResult> Plan(const PlanningScene& scene, const Task& task, const PlannerOptions& options,
                              const opt::Solver& solver);

}  // namespace quadhand::planner

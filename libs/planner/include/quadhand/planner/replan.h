// Warm-started replanning: a new plan from a measured state to the same goal,
// started from what is left of the current plan instead of a front-end search.
//
//   current plan (pieces T_0 .. T_{N-1})      t_from in piece i, local time s
//   initial guess: durations (T_i - s, T_{i+1}, .., T_{N-1}), waypoints the
//                  current plan's junctions after t_from (position, yaw and
//                  joints); a first piece shorter than min_piece_duration is
//                  merged into the next ones until it is that long (their
//                  junctions dropped)
//   start boundary: the given (measured) state; goal: the current terminal
//   solve with warm-start settings (few iterations, loose stopping rule)
//   -> the same post-check as Plan() -> raise violated weights and resume
//
// Recovery: a measured start may lie inside the safety margin (a gust pushed
// the vehicle towards a window edge). Refusing it would leave the vehicle
// holding right there, in the margin, for good; so a start whose exact
// clearance is below the safety distance but at least -max_start_penetration
// is still replanned, and its post-check uses the recovery rule
// (PostCheckOptions::recovery_time): within the first recovery_time seconds
// the clearance may never fall below the start's own clearance (minus the
// post-check's clearance tolerance, less the braking a start moving towards
// the obstacle needs, but never below -max_start_penetration), and from then
// on it must keep the full safety distance. A start deeper than that is refused (start_in_collision).
// Both are measured at the attitude the new trajectory starts with (tilted
// by the start's acceleration), as the post-check measures its first sample.
// A start outside the margin is checked exactly as Plan() checks.
//
// Rejoining: only the next `horizon` seconds are planned anew when the
// current plan goes on for longer. The new part ends at the first junction
// of the current plan at least `horizon` after the start (where there is
// none, at the last junction before the plan's end: before an insertion,
// the insertion's start), in the current
// plan's full state there (position to jerk, yaw, joints and their rates),
// and the current plan's pieces after that junction are kept as they are.
// Only the new part is solved and post-checked; the kept pieces keep the
// current plan's certificate (PostCheckReport::certified_intervals, and its
// end-state and insertion checks), which is sound because they are the same
// polynomials in the same scene: the current plan must have been checked in
// `scene`. The kept stretch must certify the full safety distance (not a
// recovery stretch). A new part that fails its attempts falls back to a
// replan of the whole remainder (the usual path above); the result's times
// and attempts include both. result.rejoined_at says where the kept pieces
// start (negative: not rejoined). A certified new part much slower than the
// current plan's way to the junction is a detour and is refused
// (ReplanOptions::max_rejoin_stretch, result.rejoin_refused_as_detour): the
// next junction is tried, with one more new piece to absorb the offset,
// up to max_rejoin_tries rejoins in all, then the whole remainder.
//
// A moving target (docs/moving_targets.md, current.moving_target): `scene`'s
// moving part is the new prediction of the target, its clock starting at
// the new plan's start; the grasp is carried from the current plan's target
// pose at its zero to the prediction's (MovingScene::target_at_zero), the
// arrival is optimised again and nothing is rejoined; a start inside the
// insertion piece (at least min_piece_duration before its end) is
// replanned as the rest of an approach that has begun (InsertionGoal::begun),
// in two pieces along the line as it now moves.
//
// The result's time 0 is the start state's time (t_from on the old clock).
// World ENU, metres, radians, seconds.
#pragma once

#include <algorithm>
#include <string>

#include "quadhand/core/status.h"
#include "quadhand/opt/solver.h"
#include "quadhand/planner/planner.h"

namespace quadhand::planner {

struct ReplanOptions {
  // Stopping rules of a warm-started solve. The guess is close to a local
  // minimum already, so a few iterations with a looser cost test recover
  // most of the improvement (DefaultReplanOptions() sets them; measured
  // figures in docs/online.md).
  opt::SolverOptions solver;
  int max_attempts = 4;  // solves (the first plus re-solves with raised weights)
  // The re-solves after a failed post-check use the planner's own stopping
  // rules (PlannerOptions::solver): with raised weights they need more steps.
  // A remaining first piece shorter than this (s) is merged into the next
  // ones until it is this long: a very short piece cannot absorb the
  // start-state offset without extreme accelerations.
  double min_piece_duration = 0.15;
  // Recovery from a start inside the safety margin (see the header comment).
  // The deepest start (m inside the scene's points, exact link meshes) still
  // replanned: a few millimetres is within the measurement and prediction
  // error of the start; deeper, the vehicle touches the obstacle and the
  // planner's free-flight model no longer holds.
  double max_start_penetration = 0.005;
  // s in which a recovering plan must be back at the safety distance. 1 s
  // stops a 1 m/s drift towards the obstacle at a quarter of a_max (4 m/s^2)
  // and leaves room to back off the margin's 3 cm.
  double recovery_time = 1.0;
  // Rejoining (see the header comment): seconds planned anew before the
  // current plan is rejoined at its next junction (or at its last one, when
  // less than this is left before it); 0 never rejoins. Solves
  // of the new part before falling back to the whole remainder. Measured
  // (docs/online.md): from 5-20 cm off the default plan, 1 s rejoins 3 of 4
  // replans; a second solve of the new part rarely passes where the first
  // failed, so a failure goes straight to the whole remainder.
  double horizon = 1.0;
  int horizon_attempts = 1;
  // A certified new part longer than this times the current plan's time to
  // the rejoin junction (or the horizon, when that is longer) is refused as
  // a detour, and a later junction (max_rejoin_tries) or the whole
  // remainder is planned to instead. The new part must meet the junction's
  // full state; from a start near or past it, the solve often finds only a
  // slow loop (on past the junction, round and back through whatever lies
  // there). Measured (docs/online.md): from 5-20 cm
  // off the default plan, the median certified part took 1.10 times its
  // guess and a third took 1.6-12 times; in real time, the narrow gap's
  // periodic replans stretched a 0.13 s part to 3.4 s and crossed the gap
  // four more times.
  double max_rejoin_stretch = 1.5;
  // Rejoins tried before the whole remainder is replanned: after a detour,
  // the next try rejoins one junction later (one more piece to absorb the
  // offset, the kept tail the current plan's smooth one).
  int max_rejoin_tries = 3;

  // The longest a certified plan for a stretch the current plan flies in
  // `planned` seconds may take before it counts as a detour
  // (max_rejoin_stretch times planned, or times the horizon when longer).
  double DetourLimit(double planned) const { return max_rejoin_stretch * std::max(planned, horizon); }

  bool IsValid(std::string* why) const;
};

ReplanOptions DefaultReplanOptions();

// The remainder of `trajectory` from t_from as an initial guess for a
// problem of `*num_pieces` pieces (see the header comment): waypoints
// 3 x (N-1) and (1 + n) x (N-1), durations N. InvalidArgument when t_from is
// outside [0, duration).
core::Status RemainderGuess(const WholeBodyTrajectory& trajectory, double t_from, double min_piece_duration,
                            MatX* position_waypoints, MatX* aux_waypoints, VecX* durations, int* first_piece);

// A new plan from `start` (measured, e.g. 10-20 cm off the current plan) to
// current.terminal, warm-started from current.trajectory's remainder after
// t_from (seconds on the current plan's clock). `task` is the task the
// current plan was made for (its goal, limits, safety distance); its start is
// replaced by `start`. Ordinary outcomes are PlanResults with success false:
// status "insertion_in_progress" (t_from lies in the insertion piece of a
// still goal, or too near a moving one's end: a plan starting partway down
// the insertion line to a still goal cannot pass the insertion check),
// "start_in_collision" (the measured state is more than
// max_start_penetration inside the scene), "representation_failed", or the
// statuses of SolveAndPostCheck (planner.h). A start inside the safety margin is judged
// by the recovery rule (result.post_check.recovery is then true).
// InvalidArgument for inconsistent input (no current trajectory, joint
// counts, invalid options).
core::Result<PlanResult> Replan(const PlanningScene& scene, const Task& task, const PlannerOptions& options,
                                const ReplanOptions& replan, const opt::Solver& solver, const PlanResult& current,
                                double t_from, const BoundaryState& start);

}  // namespace quadhand::planner

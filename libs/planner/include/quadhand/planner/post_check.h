// The planner's own verdict on a trajectory: it must keep the safety
// distance from every obstacle point (exact link meshes) and the robot's
// links apart from each other at every instant - certified between the
// samples, not only at them (docs/certificate.md) - and, at the samples,
// every limit, the joint limits, the start and end states, and a straight
// tool approach over the insertion. "Success" means all hold.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "quadhand/core/status.h"
#include "quadhand/env/collision_model.h"
#include "quadhand/env/exact_mesh_model.h"
#include "quadhand/env/self_collision.h"
#include "quadhand/planner/moving_scene.h"
#include "quadhand/planner/plan_status.h"
#include "quadhand/planner/task.h"
#include "quadhand/planner/whole_body_problem.h"

namespace quadhand::planner {

struct PostCheckOptions {
  double dt = 0.01;                        // sampling step, seconds (at most the plan's --dt)
  // Spacing of the clearance samples, seconds: every regular sample within
  // it is checked against the limits, and the clearances measured here are
  // certified in between, refined where needed (docs/certificate.md). At
  // most dt is the same as dt.
  double clearance_dt = 0.04;
  double clearance_tolerance = 0.002;      // metres below the safety distance still accepted
  double limit_tolerance = 0.02;           // relative excess over a limit still accepted
  double position_tolerance = 0.01;        // start/end position, metres
  double angle_tolerance = 0.02;           // start/end yaw and joints, radians
  double rate_tolerance = 0.05;            // end velocity (m/s) and rates (rad/s) against the terminal's (at rest: zero)
  double insertion_tolerance = 0.01;       // tool distance from the insertion line, metres
  // Recovery stretch, seconds (0 = off; Plan() leaves it off, replans from a
  // measured state set it: ReplanOptions::recovery_time). When it is on and
  // the trajectory STARTS closer than the safety distance (minus
  // clearance_tolerance), the clearance check becomes: over [0,
  // recovery_time) the clearance never falls below the start's own clearance
  // minus clearance_tolerance (never worse than where it starts, except for
  // the braking a start moving towards the obstacle needs:
  // PostCheckReport::recovery_braking_allowance), and from
  // recovery_time on (the last sample always) it is back at the safety
  // distance minus clearance_tolerance. A start outside the margin is checked
  // exactly as without it.
  double recovery_time = 0.0;
  // The stretch's bound (before clearance_tolerance) never goes below this
  // clearance, metres (<= 0): a braking allowance that would take the
  // vehicle deeper into the scene than this fails the check instead
  // (contact, where the free-flight model no longer holds). Replans set it
  // to -ReplanOptions::max_start_penetration.
  double recovery_min_clearance = -0.005;
  // Workers measuring the samples (0: one per core). The report does not
  // depend on it: the samples are reduced in time order.
  int threads = 0;
  // For a trajectory that is re-solved when it fails (every solve of a plan
  // but its last): the clearances are measured and certified in time order,
  // a few tenths of a second at a time, and no more after the stretch in
  // which the clearance or self-clearance first fails; the limits, states
  // and insertion are still checked at every sample. A failing check then
  // costs what its first failure costs, and its verdict is the same (failed);
  // the report's clearance figures cover [0, clearance_checked_until] only.
  bool stop_at_first_failure = false;

  bool IsValid(std::string* why) const;
};

// The certificate of one stretch between two clearance samples: lower bounds
// of the exact clearance and of the checked links' self-distance at every
// instant of [t0, t1] (capped like the report's values), the least exact
// clearance measured in it (its ends and any samples the certificate added)
// and the one measured at t1. A replan that rejoins this trajectory keeps these
// for the pieces it leaves unchanged (replan.h).
struct CertifiedInterval {
  double t0 = 0.0, t1 = 0.0;
  double clearance_lower = 0.0;
  double self_distance_lower = 0.0;
  double clearance_sampled = 0.0, clearance_at_t1 = 0.0;
};

// One check: `value` measured against `bound`; `ratio` = value / bound for
// limits (1.0 = at the bound), or the worst excess for tolerances.
struct CheckResult {
  CheckKind kind = CheckKind::kClearance;
  int joint = -1;    // the actuated joint of a kJointRate check
  std::string name;  // for people: CheckKindName(kind), or "<joint>_rate"
  bool passed = true;
  double value = 0.0;
  double bound = 0.0;
  double time = 0.0;  // where the worst value occurred, seconds
  std::string detail;
};

struct PostCheckReport {
  bool passed = false;
  std::vector<CheckResult> checks;
  double min_clearance_exact = 0.0;   // link meshes vs raw points, least over the samples
  double min_clearance_model = 0.0;   // as the planner's collision model measures it
  int closest_link = -1;
  // min_clearance_exact is where a sample's search stopped with nothing
  // found (each sample searches out to at least the safety distance + 1 cm
  // and at most ClearanceSearchReach): a lower bound, not a measured
  // distance, and there is no closest link.
  bool min_clearance_exact_is_bound = false;
  // Lower bound of the smallest distance between checked robot link pairs
  // (env/self_collision.h), capped at self_safety_distance + 0.02 m, and the
  // pair's index in SelfCollisionModel::pairs() (-1: none that close).
  double min_self_distance = 0.0;
  int closest_self_pair = -1;
  double start_clearance_exact = 0.0; // at t = 0
  // The continuous-time certificate (docs/certificate.md): lower bounds of
  // the exact clearance and of the links' self-distance at every instant of
  // the trajectory (capped like the sampled values), and how many samples it
  // added between the regular ones. The clearance and self_clearance checks
  // judge these, so "passed" means certified.
  bool certified = false;             // both hold at every instant (within the tolerance)
  double certified_clearance = 0.0;
  double certified_margin = 0.0;      // certified_clearance less the distance it had to keep (negative: within the tolerance)
  double certified_self_distance = 0.0;
  int certificate_samples = 0;
  // Where the clearances were measured and certified up to: the duration,
  // or less when PostCheckOptions::stop_at_first_failure stopped them.
  double clearance_checked_until = 0.0;
  // Per stretch between clearance samples, in time order, covering
  // [0, clearance_checked_until].
  std::vector<CertifiedInterval> certified_intervals;
  bool recovery = false;              // the recovery rule judged the clearance (see recovery_time)
  // Under the recovery rule: how much lower than the start's clearance (less
  // the tolerance) the stretch may go because the start is moving towards
  // the obstacle: v^2 / (2 a_max), v the rate at which the start's own
  // motion closes its clearance. 0 for a start moving away.
  double recovery_braking_allowance = 0.0;
  // Per via of the task, in order: when the base came closest to it (the
  // via check), seconds.
  std::vector<double> via_times;
  // Worst ratio of each limit (1.0 = at the bound): v, a, yaw_rate, body_rate_xy, joint rates.
  std::vector<std::pair<std::string, double>> violations;
  std::string FirstFailure() const;   // "clearance: 0.021 m < 0.028 m at t = 3.2 s", or empty
};

// Checks `trajectory` for `task` (whose joint limits ApplyRobot filled).
// `insertion` is the straight approach the plan had to make (enabled or not).
// `self_collision` (null: none) holds the link pairs that must keep the
// task's self_safety_distance. With `moving` (a moving target:
// docs/moving_targets.md), `exact` and `model` hold the still points, the
// moving points are measured where they are at each sample's time and the
// certificate adds their speed to the robot's; `insertion` is the target's
// at t = 0, and the tool is measured against it in the target's frame;
// `terminal` is the goal state at the trajectory's end; and with
// goal.tool.max_relative_speed the tool's speed relative to the target at
// the end is checked (relative_speed).
PostCheckReport PostCheck(const WholeBodyTrajectory& trajectory, const robot::RobotModel& robot, const Task& task,
                          const BoundaryState& terminal, const InsertionGoal& insertion,
                          const env::CollisionModel& model, const env::ExactMeshModel& exact,
                          const env::SelfCollisionModel* self_collision, const PostCheckOptions& options,
                          const MovingScene* moving = nullptr);

}  // namespace quadhand::planner

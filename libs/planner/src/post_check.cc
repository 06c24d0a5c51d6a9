#include "quadhand/planner/post_check.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>

#include "quadhand/core/text.h"
#include "quadhand/core/worker_pool.h"
#include "quadhand/planner/motion_bound.h"
#include "quadhand/robot/kinematics.h"

#include "sampled_checks.h"

namespace quadhand::planner {
namespace {

using core::Format;

// Tracks the least value of one quantity, when and where (a link or pair
// index) it occurred; the first of equal values is kept.
struct Least {
  double value = 1e300;
  double time = 0.0;
  int index = -1;
  void Take(double v, double t, int i) {
    if (v < value) {
      value = v;
      time = t;
      index = i;
    }
  }
};

// More samples than this is a trajectory far longer than any plan, or a dt
// far finer than any check needs: refused (a failed check) rather than run
// for hours.
constexpr double kMaxPostCheckSamples = 1e6;

}  // namespace

bool PostCheckOptions::IsValid(std::string* why) const {
  for (double v : {dt, clearance_dt, clearance_tolerance, limit_tolerance, position_tolerance, angle_tolerance, rate_tolerance,
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
  if (!(clearance_dt >= 1e-4 && clearance_dt <= 10.0)) {
    if (why != nullptr) *why = "post-check clearance_dt must be in [0.0001, 10] s";
    return false;
  }
  if (!(std::isfinite(recovery_min_clearance) && recovery_min_clearance <= 0.0)) {
    if (why != nullptr) *why = "post-check recovery_min_clearance must be finite and at most 0";
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
                          const env::SelfCollisionModel* self_collision, const PostCheckOptions& options,
                          const MovingScene* moving) {
  PostCheckReport report;
  if (moving != nullptr && !moving->moves()) moving = nullptr;
  const Limits& limits = task.limits;
  const double duration = trajectory.duration();
  const double wanted_steps = std::ceil(duration / options.dt - 1e-9);
  if (!(wanted_steps <= kMaxPostCheckSamples)) {  // also a non-finite duration
    report.checks.push_back({CheckKind::kSampling, -1, CheckKindName(CheckKind::kSampling), false, wanted_steps,
                             kMaxPostCheckSamples, 0.0,
                             Format("a %.3g s trajectory needs %.3g samples at dt = %.3g s", duration, wanted_steps,
                                    options.dt) +
                                 Format("; at most %.0f are checked", kMaxPostCheckSamples)});
    report.passed = false;
    return report;
  }
  const int steps = std::max(1, static_cast<int>(wanted_steps));
  const double reach = ClearanceSearchReach(task);

  const bool check_self = self_collision != nullptr && !self_collision->pairs().empty();
  const double self_reach = SelfClearanceSearchReach(task);
  const double clearance_bound = AcceptedClearance(task, options.clearance_tolerance);
  const double self_bound = AcceptedSelfClearance(task, options.clearance_tolerance);
  const RobotMotionBound motion(robot, exact);
  // Moving points close on the robot at up to their own speed too: the
  // certificate's bound S is the robot's plus theirs.
  const double moving_speed = moving != nullptr ? moving->PointSpeed(duration) : 0.0;

  // What one sample measures. The samples are measured on `threads` workers,
  // each writing only its own entries; the reduction below visits them in
  // time order, so the verdict is the same to the last bit for any count.
  // Every regular sample is checked against the limits (and the insertion
  // line); the clearances are measured at every `clearance_every`-th one and
  // the last, and certified in between (refined where needed): the
  // certificate, not the spacing, makes them hold at every instant, so the
  // spacing only trades measurements against refinements.
  const int clearance_every = std::max(1, static_cast<int>(std::floor(options.clearance_dt / options.dt + 1e-9)));
  // With stop_at_first_failure, no clearance is measured after the block in
  // which the clearance (or self-clearance) first failed.
  bool clearance_stopped = false;
  auto is_clearance_step = [&](int step) {
    return !clearance_stopped && (step % clearance_every == 0 || step == steps);
  };
  auto previous_clearance_step = [&](int step) {
    return step % clearance_every == 0 ? step - clearance_every : step - step % clearance_every;
  };
  struct Measured {
    double t = 0.0;
    WholeBodySample sample;
    bool has_clearance = false;
    double d_exact = 0.0, d_self = 0.0, d_model = 0.0;
    int link = -1, pair = -1;
    Vec3 tool = Vec3::Zero();
  };
  enum class Measure { kLimits, kRegular, kRefinement };
  // How far a sample's clearance searches look. A value capped at
  // bound + S h / 2 still certifies an interval of length h and speed bound S
  // (docs/certificate.md), so the search of a sample stops there for the
  // longer reach of its two intervals: near the scene the robot is slow and
  // the search is short. A capped value is still a lower bound, so nothing
  // else changes. Clearances below the safety distance + 1 cm are always
  // measured exactly (the report's sampled minimum), none beyond `reach`.
  constexpr double kRadiusMargin = 0.002, kExactBelow = 0.01;
  auto search_radii = [&](double t, double h_before, double h_after) {
    double world = 0.0, relative = 0.0;
    for (const auto& [t0, t1] : {std::pair{t - h_before, t}, std::pair{t, t + h_after}}) {
      if (!(t1 > t0)) continue;
      const PointSpeedBound speed = motion.Over(trajectory, t0, t1);
      world = std::max(world, (speed.world + moving_speed) * (t1 - t0));
      relative = std::max(relative, speed.relative * (t1 - t0));
    }
    return std::pair{
        std::min(reach, std::max(task.safety_distance + kExactBelow, clearance_bound + 0.5 * world + kRadiusMargin)),
        std::min(self_reach, std::max(task.self_safety_distance + kExactBelow,
                                      self_bound + 0.5 * relative + kRadiusMargin))};
  };
  auto measure_at = [&](double t, Measure what, robot::KinematicsState* kinematics, Measured* m,
                        std::pair<double, double> radii = {}) {
    m->t = t;
    m->sample = trajectory.Sample(t);
    m->has_clearance = what != Measure::kLimits;
    if (what == Measure::kLimits && !insertion.enabled) return;
    robot::ComputeKinematics(robot, m->sample.BasePose(), m->sample.joints, kinematics);
    // A moving target's displacement at t: the tool and the moving points
    // are judged in its frame at t = 0.
    const Pose displacement = moving != nullptr ? moving->motion->Displacement(t) : Pose::Identity();
    if (insertion.enabled) {
      m->tool = kinematics->link_poses[insertion.tool_link].translation();
      if (moving != nullptr && moving->goal_moves) m->tool = displacement.inverse() * m->tool;
    }
    if (what == Measure::kLimits) return;
    m->d_exact = env::WholeBodyClearance(*kinematics, exact, radii.first, {}, &m->link);
    std::optional<robot::KinematicsState> in_target_frame;
    if (moving != nullptr && moving->has_points()) {
      in_target_frame = InTargetFrameAtZero(*kinematics, displacement);
      int link = -1;
      const double d = env::WholeBodyClearance(*in_target_frame, *moving->exact, radii.first, {}, &link);
      if (d < m->d_exact) {
        m->d_exact = d;
        m->link = link;
      }
    }
    m->d_self = radii.second;
    if (check_self) m->d_self = self_collision->MinDistanceLowerBound(*kinematics, radii.second, &m->pair);
    if (what == Measure::kRegular) {
      int piece = 0;
      double local = 0;
      trajectory.position().LocatePiece(t, &piece, &local);
      m->d_model = env::WholeBodyClearance(*kinematics, model, reach, env::QueryContext{piece, local});
      if (in_target_frame && moving->collision != nullptr) {
        m->d_model = std::min(m->d_model, env::WholeBodyClearance(*in_target_frame, *moving->collision, reach,
                                                                  env::QueryContext{piece, local}));
      }
    }
  };
  // Whether the clearance between two samples is judged by the recovery
  // stretch's bound (PostCheckOptions::recovery_time); decided by sample 0.
  bool recovery = false;
  double stretch_bound = clearance_bound;
  auto bound_between = [&](double t1) {
    return recovery && t1 < options.recovery_time && t1 < duration ? stretch_bound : clearance_bound;
  };

  // The certificate of one interval between samples (docs/certificate.md):
  // from the clearances at its ends and a bound S of how fast any point of
  // the robot moves within it, no instant has less than
  //   min(d0, d1, (d0 + d1 - S h) / 2);
  // where that is not enough the interval is halved at a new sample, up to
  // kMaxHalvings times. A sample already below its bound fails the check:
  // nothing is refined there.
  struct Certified {
    double lower = 1e300, lower_time = 0.0, bound = 0.0;  // least slack interval
    double least_lower = 1e300;                            // least bound over its parts
    double self_lower = 1e300, self_time = 0.0;
    bool undefined = false;  // the attitude is undefined somewhere (free fall, inverted)
    double undefined_time = 0.0;
    int added = 0;
    // The added sample with the least exact clearance (link), and the one
    // with the least self-distance (pair).
    Least closest, closest_self;
  };
  constexpr int kMaxHalvings = 8;
  auto certify = [&](const Measured& first, const Measured& last, int max_halvings, robot::KinematicsState* kinematics,
                     Certified* c) {
    struct Piece {
      double t0, d0, s0, t1, d1, s1;
      int depth;
    };
    *c = Certified{};
    std::vector<Piece> stack{{first.t, first.d_exact, first.d_self, last.t, last.d_exact, last.d_self, 0}};
    Measured mid;
    while (!stack.empty()) {
      const Piece p = stack.back();
      stack.pop_back();
      const double h = p.t1 - p.t0;
      const double bound = bound_between(p.t1);
      const PointSpeedBound speed = motion.Over(trajectory, p.t0, p.t1);
      auto lower_of = [h](double d0, double d1, double s, double t0, double* at) {
        const double lower = std::min({d0, d1, 0.5 * (d0 + d1 - s * h)});
        *at = t0 + (s > 0.0 ? std::clamp((d0 - d1 + s * h) / (2.0 * s), 0.0, h) : 0.0);
        return lower;
      };
      double at = p.t0, self_at = p.t0;
      const bool finite = std::isfinite(speed.world) && std::isfinite(speed.relative);
      const double lower =
          finite ? lower_of(p.d0, p.d1, speed.world + moving_speed, p.t0, &at) : std::min(p.d0, p.d1);
      const double self_lower =
          !check_self ? 1e300 : finite ? lower_of(p.s0, p.s1, speed.relative, p.t0, &self_at) : std::min(p.s0, p.s1);
      const bool holds = finite && lower >= bound && self_lower >= self_bound;
      const bool sampled_fails = std::min(p.d0, p.d1) < bound || (check_self && std::min(p.s0, p.s1) < self_bound);
      if (holds || sampled_fails || !finite || p.depth >= max_halvings) {
        if (!finite && !c->undefined) {
          c->undefined = true;
          c->undefined_time = p.t0;
        }
        c->least_lower = std::min(c->least_lower, lower);
        if (lower - bound < c->lower - c->bound) {
          c->lower = lower;
          c->lower_time = at;
          c->bound = bound;
        }
        if (self_lower < c->self_lower) {
          c->self_lower = self_lower;
          c->self_time = self_at;
        }
        continue;
      }
      measure_at(0.5 * (p.t0 + p.t1), Measure::kRefinement, kinematics, &mid,
                 search_radii(0.5 * (p.t0 + p.t1), 0.5 * h, 0.5 * h));
      ++c->added;
      c->closest.Take(mid.d_exact, mid.t, mid.link);
      c->closest_self.Take(mid.d_self, mid.t, mid.pair);
      // Later half first on the stack: the earlier half is refined first.
      stack.push_back({mid.t, mid.d_exact, mid.d_self, p.t1, p.d1, p.s1, p.depth + 1});
      stack.push_back({p.t0, p.d0, p.s0, mid.t, mid.d_exact, mid.d_self, p.depth + 1});
    }
  };

  // Blocks of samples bound the memory; within a block, worker `first`
  // takes every `stride`-th sample (then every stride-th interval), so the
  // costly ones (near the scene, at the end of a grasp) are spread over all
  // workers. Stopping at the first failure, blocks of 8 clearance intervals
  // (0.32 s at the defaults) are where it can stop.
  const int block_size = options.stop_at_first_failure ? 8 * clearance_every : 4096;
  std::vector<Measured> measured(std::min(steps + 1, block_size));
  std::vector<Certified> certified(measured.size());
  Measured previous;  // the last clearance sample before the block
  int block_begin = 0, block_end = 0;
  std::vector<int> to_certify;  // the block's clearance steps after the first of all
  auto time_of = [&](int step) { return std::min(duration, step * duration / steps); };
  std::vector<int> measure_order;  // the block's clearance steps, then the others: spread evenly over the workers
  auto measure = [&](int first, int stride) {
    robot::KinematicsState kinematics;
    for (size_t i = first; i < measure_order.size(); i += stride) {
      const int step = measure_order[i];
      const double t = time_of(step);
      if (!is_clearance_step(step)) {
        measure_at(t, Measure::kLimits, &kinematics, &measured[step - block_begin]);
        continue;
      }
      const double before = step > 0 ? t - time_of(previous_clearance_step(step)) : 0.0;
      const double after = step < steps ? time_of(std::min(steps, step + clearance_every)) - t : 0.0;
      measure_at(t, Measure::kRegular, &kinematics, &measured[step - block_begin], search_radii(t, before, after));
    }
  };
  auto certify_interval = [&](int step, int max_halvings, robot::KinematicsState* kinematics) {
    const int before = previous_clearance_step(step);
    certify(before >= block_begin ? measured[before - block_begin] : previous, measured[step - block_begin],
            max_halvings, kinematics, &certified[step - block_begin]);
  };
  auto certify_block = [&](int first, int stride) {
    robot::KinematicsState kinematics;
    for (size_t i = first; i < to_certify.size(); i += stride) certify_interval(to_certify[i], kMaxHalvings, &kinematics);
  };
  // One pool for every block's two passes (measure, then certify).
  core::WorkerPool pool(core::WorkerCount(options.threads, std::min(steps + 1, block_size)));
  auto run_on_workers = [&](auto&& work) { pool.Run([&](int worker) { work(worker, pool.size()); }); };

  // The checks judged at the regular samples (sampled_checks.h), fed in time order.
  const CheckInputs check_inputs{trajectory, robot, task, terminal, insertion, options};
  const std::vector<std::unique_ptr<SampledCheck>> sampled_checks = MakeSampledChecks(check_inputs);
  Least exact_least{reach};  // over every sample measured, regular and added
  double min_model = reach;
  Least self_least{self_reach};
  // The certificate: the least slack over the intervals, and where.
  double certified_slack = 1e300, certified_lower = 0.0, certified_time = 0.0, certified_against = clearance_bound;
  double certified_self = self_reach, certified_self_time = 0.0;
  bool undefined_motion = false;
  double undefined_time = 0.0;
  int added = 0;
  double previous_clearance_time = 0.0, previous_clearance_value = 0.0;
  auto take_self = [&](double d, double t, int pair) {
    if (check_self) self_least.Take(d, t, pair);
  };
  for (block_begin = 0; block_begin <= steps; block_begin = block_end) {
    block_end = std::min(steps + 1, block_begin + block_size);
    measure_order.clear();
    for (int step = block_begin; step < block_end; ++step) {
      if (is_clearance_step(step)) measure_order.push_back(step);
    }
    for (int step = block_begin; step < block_end; ++step) {
      if (!is_clearance_step(step)) measure_order.push_back(step);
    }
    run_on_workers(measure);
    to_certify.clear();
    for (int step = std::max(1, block_begin); step < block_end; ++step) {
      if (is_clearance_step(step)) to_certify.push_back(step);
    }
    if (block_begin == 0) {
      report.start_clearance_exact = measured[0].d_exact;
      recovery = options.recovery_time > 0.0 && report.start_clearance_exact < clearance_bound;
      if (recovery) {
        // A start moving towards the obstacle cannot stop at once: the
        // stretch also allows the distance braking at the acceleration limit
        // takes, v^2 / (2 a_max), v the rate at which the start's own motion
        // closes its clearance (over the first millisecond the plan cannot
        // change that motion: it starts with the measured velocity). Not a
        // reason to judge a start outside the margin by this rule: passing an
        // edge closes the clearance too, and then slows its closing by
        // itself, with no braking.
        robot::KinematicsState kinematics;
        Measured soon;
        const double epsilon = std::min(1e-3, duration);
        if (epsilon > 0.0) measure_at(epsilon, Measure::kRefinement, &kinematics, &soon, {reach, self_reach});
        const double closing = epsilon > 0.0 ? std::max(0.0, (report.start_clearance_exact - soon.d_exact) / epsilon) : 0.0;
        report.recovery_braking_allowance = closing * closing / (2.0 * limits.a_max);
      }
      stretch_bound = std::max(options.recovery_min_clearance,
                               report.start_clearance_exact - report.recovery_braking_allowance) -
                      options.clearance_tolerance;
    }
    // More added samples than the regular ones over the whole trajectory
    // means a plan grazing the scene nearly everywhere: the rest is not
    // refined (it fails unless the unrefined bound holds) rather than
    // multiplying the work.
    if (added <= 4 * (steps + 1)) {
      run_on_workers(certify_block);
    } else {
      robot::KinematicsState kinematics;
      for (int step : to_certify) certify_interval(step, 0, &kinematics);
    }
  for (int index = 0; index < block_end - block_begin; ++index) {
    const Measured& m = measured[index];
    const double t = m.t;
    const WholeBodySample& s = m.sample;
    if (m.has_clearance) {
      exact_least.Take(m.d_exact, t, m.link);
      take_self(m.d_self, t, m.pair);
      min_model = std::min(min_model, m.d_model);
    }
    if (m.has_clearance && block_begin + index > 0) {
      const Certified& c = certified[index];
      report.certified_intervals.push_back({previous_clearance_time, t, c.least_lower, std::min(c.self_lower, self_reach),
                                            std::min({previous_clearance_value, m.d_exact, c.closest.value}), m.d_exact});
      exact_least.Take(c.closest.value, c.closest.time, c.closest.index);
      take_self(c.closest_self.value, c.closest_self.time, c.closest_self.index);
      added += c.added;
      if (c.lower - c.bound < certified_slack) {
        certified_slack = c.lower - c.bound;
        certified_lower = c.lower;
        certified_time = c.lower_time;
        certified_against = c.bound;
      }
      if (c.self_lower < certified_self) {
        certified_self = c.self_lower;
        certified_self_time = c.self_time;
      }
      if (c.undefined && !undefined_motion) {
        undefined_motion = true;
        undefined_time = c.undefined_time;
      }
    }
    if (m.has_clearance) {
      previous_clearance_time = t;
      previous_clearance_value = m.d_exact;
    }
    for (const auto& check : sampled_checks) check->Observe(CheckedSample{t, &s, m.tool});
  }
    if (previous_clearance_step(block_end) >= block_begin) {
      previous = measured[previous_clearance_step(block_end) - block_begin];
    }
    if (options.stop_at_first_failure && !clearance_stopped && block_end <= steps &&
        (certified_slack < 0.0 || undefined_motion || (check_self && certified_self < self_bound))) {
      clearance_stopped = true;
      report.clearance_checked_until = previous.t;
    }
  }
  if (!clearance_stopped) report.clearance_checked_until = duration;
  const double min_exact = exact_least.value, min_exact_time = exact_least.time;
  const int closest = exact_least.index;
  const double min_self = self_least.value, min_self_time = self_least.time;
  const int closest_self = self_least.index;
  report.min_clearance_exact = min_exact;
  report.min_clearance_model = min_model;
  report.closest_link = closest;
  report.min_clearance_exact_is_bound = closest < 0;
  report.recovery = recovery;
  report.certificate_samples = added;
  report.certified_clearance = certified_lower;
  report.certified_self_distance = check_self ? certified_self : self_reach;

  auto add = [&report](CheckKind kind, int joint, std::string name, bool passed, double value, double bound,
                        double time, std::string detail) {
    report.checks.push_back({kind, joint, std::move(name), passed, value, bound, time, std::move(detail)});
  };
  const std::string closest_name = closest >= 0 ? ", link " + robot.link(closest).name : "";
  const std::string sampled =
      Format("; sampled minimum %.4f m at t = %.3f s", min_exact, min_exact_time) + closest_name +
      (clearance_stopped ? Format("; clearances checked up to t = %.3f s of %.3f s (stopped at the first failure)",
                                  report.clearance_checked_until, duration)
                         : std::string());
  if (undefined_motion) {
    add(CheckKind::kClearance, -1, "clearance", false, min_exact, task.safety_distance, undefined_time,
        Format("no clearance certificate from t = %.3f s: the attitude is not defined by the flat outputs there "
               "(free fall or inverted)",
               undefined_time) +
            sampled);
  } else if (!recovery) {
    add(CheckKind::kClearance, -1, "clearance", certified_slack >= 0.0, certified_lower, task.safety_distance,
        certified_time,
        Format("certified exact clearance %.4f m at every instant (safety distance %.4f m, accepted down to %.4f m)",
               certified_lower, task.safety_distance, clearance_bound) +
            Format(", least at t = %.3f s", certified_time) + sampled);
  } else {
    // The recovery rule (PostCheckOptions::recovery_time): the start's
    // clearance during the stretch and the safety distance after it; the
    // check reports the interval with the least slack.
    const double start = report.start_clearance_exact;
    add(CheckKind::kClearance, -1, "clearance", certified_slack >= 0.0, certified_lower,
        certified_against + options.clearance_tolerance, certified_time,
        Format("recovery from %.4f m at the start (within %.2f s: ", start, options.recovery_time) +
            (report.recovery_braking_allowance > 0.0
                 ? Format("braking allowance %.4f m, ", report.recovery_braking_allowance)
                 : std::string()) +
            Format("no lower than %.4f m, then the safety distance %.4f m): ", stretch_bound + options.clearance_tolerance,
                   task.safety_distance) +
            Format("certified exact clearance %.4f m at t = %.3f s, accepted down to %.4f m", certified_lower,
                   certified_time, certified_against) +
            sampled);
  }
  report.min_self_distance = min_self;
  report.closest_self_pair = closest_self;
  if (check_self) {
    std::string pair_names;
    if (closest_self >= 0) {
      const env::LinkPair& pair = self_collision->pairs()[closest_self];
      pair_names = ", links " + robot.link(pair.sampled_link).name + " and " + robot.link(pair.queried_link).name;
    }
    add(CheckKind::kSelfClearance, -1, "self_clearance", !undefined_motion && certified_self >= self_bound,
        certified_self, task.self_safety_distance, certified_self_time,
        Format("robot links certified %.4f m apart at every instant (self-safety distance %.4f m), least at t = %.3f s",
               certified_self, task.self_safety_distance, certified_self_time) +
            Format("; sampled minimum %.4f m at t = %.3f s", min_self, min_self_time) + pair_names);
  }
  report.certified_margin = certified_slack - options.clearance_tolerance;
  report.certified = true;
  for (const CheckResult& check : report.checks) report.certified = report.certified && check.passed;
  for (const auto& check : sampled_checks) check->Finish(&report);
  if (moving != nullptr && moving->goal_moves && insertion.enabled && task.tool && task.tool->moving &&
      task.tool->moving->max_relative_speed) {
    // The tool's velocity at the end (a one-sided difference over 1 ms of
    // the trajectory) against the target point's where the tool is.
    constexpr double kStep = 1e-3;
    auto tool_at = [&](double t) {
      const WholeBodySample sample = trajectory.Sample(t);
      return robot::LinkPose(robot, sample.BasePose(), sample.joints, insertion.tool_link).translation();
    };
    const double end = duration;
    const double step = std::min(kStep, 0.5 * end);
    const Vec3 tool = tool_at(end);
    const Vec3 tool_velocity = (tool - tool_at(end - step)) / step;
    const double relative = (tool_velocity - moving->motion->PointVelocity(tool, end)).norm();
    const double bound = *task.tool->moving->max_relative_speed;
    report.checks.push_back({CheckKind::kRelativeSpeed, -1, CheckKindName(CheckKind::kRelativeSpeed),
                             relative <= bound * (1.0 + options.limit_tolerance), relative, bound, end,
                             Format("the tool moves at %.4f m/s relative to the target at the arrival (at most %.4f)",
                                    relative, bound)});
  }
  report.passed = true;
  for (const CheckResult& check : report.checks) report.passed = report.passed && check.passed;
  return report;
}

}  // namespace quadhand::planner

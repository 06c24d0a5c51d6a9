#include "quadhand/online/controller.h"

#include "perception_map.h"
#include "quadhand/core/text.h"
#include "quadhand/planner/time_scale.h"
#include "quadhand/robot/kinematics.h"
#include "quadhand/traj/flatness.h"

#include <algorithm>
#include <limits>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <mutex>
#include <thread>

#ifdef __linux__
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>
#endif

namespace quadhand::online {
namespace {

using core::Format;

// Plans are made for this share of the speed the link allows, and the
// vehicle brakes for the link only above kLinkHoldSlack times that speed:
// the gap keeps ordinary jitter from braking a plan made for the link.
constexpr double kLinkPlanningShare = 0.7;
constexpr double kLinkHoldSlack = 1.5;
constexpr double kLinkSettleTime = 1.0;  // s of link figures before the first plan
constexpr double kRestSpeed = 0.05;      // m/s: a holding vehicle, planned from rest
constexpr double kLatestTargetStart = 0.05;     // s a moving target's plan may be entered after its t = 0
constexpr double kSettledRelativeSpeed = 0.02;  // m/s: settled above a moving target
constexpr double kLastTailReplan = 1.0;         // s before the arrival: no tail replan after

// "<what> (<status>: <message>)": the words for a plan that failed.
std::string FailedPlanWords(const char* what, const PlanRecord& record) {
  return std::string(what) + " (" + planner::PlanStatusName(record.status) + ": " + record.message + ")";
}

}  // namespace

const char* AutopilotModeName(AutopilotMode mode) {
  switch (mode) {
    case AutopilotMode::kOffboard: return "OFFBOARD";
    case AutopilotMode::kPosition: return "POSITION";
    case AutopilotMode::kHold: return "HOLD";
    case AutopilotMode::kLand: return "LAND";
    case AutopilotMode::kOther: return "another mode";
    case AutopilotMode::kUnknown: break;
  }
  return "an unknown mode";
}

const char* HoldCauseName(HoldCause cause) {
  switch (cause) {
    case HoldCause::kNone: return "none";
    case HoldCause::kPlanFailed: return "the plan failed";
    case HoldCause::kLinkFailed: return "the link failed during the mission";
    case HoldCause::kToolNotSettled: return "the tool did not settle";
    case HoldCause::kGripperFailed: return "the gripper did not act";
    case HoldCause::kTargetLost: return "the target was lost";
  }
  return "?";
}

const char* PhaseName(Phase phase) {
  switch (phase) {
    case Phase::kWaitingForVehicle: return "waiting_for_vehicle";
    case Phase::kStreamingHold: return "streaming_hold";
    case Phase::kRequestingOffboard: return "requesting_offboard";
    case Phase::kArming: return "arming";
    case Phase::kWaitingForPlan: return "waiting_for_plan";
    case Phase::kFlying: return "flying";
    case Phase::kArrived: return "arrived";
    case Phase::kHoldingAfterFailure: return "holding_after_failure";
    case Phase::kVehicleLost: return "vehicle_lost";
    case Phase::kHandshakeFailed: return "handshake_failed";
  }
  return "?";
}

bool OnlineOptions::IsValid(std::string* why) const {
  auto fail = [why](const char* message) {
    if (why != nullptr) *why = message;
    return false;
  };
  auto positive = [](double v) { return std::isfinite(v) && v > 0.0; };
  if (!positive(hold_time)) return fail("hold_time must be positive");
  if (!positive(ack_timeout)) return fail("ack_timeout must be positive");
  if (max_command_attempts < 1) return fail("max_command_attempts must be at least 1");
  if (!positive(vehicle_timeout)) return fail("vehicle_timeout must be positive");
  if (!(std::isfinite(outage_timeout) && outage_timeout >= vehicle_timeout)) {
    return fail("outage_timeout must be at least vehicle_timeout");
  }
  if (!positive(resume_tolerance)) return fail("resume_tolerance must be positive");
  if (!positive(connect_timeout)) return fail("connect_timeout must be positive");
  if (!positive(replan_threshold)) return fail("replan_threshold must be positive");
  if (!(std::isfinite(min_replan_interval) && min_replan_interval >= 0.0)) return fail("min_replan_interval must be >= 0");
  if (!(std::isfinite(replan_lead) && replan_lead >= 0.0)) return fail("replan_lead must be >= 0");
  if (!(std::isfinite(replan_period) && replan_period >= 0.0)) return fail("replan_period must be >= 0 (0: off)");
  if (!positive(periodic_max_velocity_error)) return fail("periodic_max_velocity_error must be positive");
  if (!positive(blend_window)) return fail("blend_window must be positive");
  if (!positive(start_tolerance)) return fail("start_tolerance must be positive");
  if (!(std::isfinite(settle_timeout) && settle_timeout >= 0.0)) return fail("settle_timeout must be >= 0");
  if (!(std::isfinite(arrival_hold) && arrival_hold >= 0.0)) return fail("arrival_hold must be >= 0");
  if (!positive(arrival_tolerance)) return fail("arrival_tolerance must be positive");
  if (!positive(arrival_settle_speed)) return fail("arrival_settle_speed must be positive");
  if (!(std::isfinite(arrival_timeout) && arrival_timeout >= arrival_hold)) {
    return fail("arrival_timeout must be finite and >= arrival_hold");
  }
  if (!positive(heartbeat_period)) return fail("heartbeat_period must be positive");
  if (const char* clock_why = nullptr; !clock_sync.IsValid(&clock_why)) return fail(clock_why);
  if (!positive(max_state_age)) return fail("max_state_age must be positive");
  if (!positive(link_budget)) return fail("link_budget must be positive");
  if (!positive(min_link_speed)) return fail("min_link_speed must be positive");
  if (!positive(max_blind_time)) return fail("max_blind_time must be positive");
  if (!(std::isfinite(clearance_tolerance) && clearance_tolerance >= 0.0)) {
    return fail("clearance_tolerance must be >= 0");
  }
  if (!positive(max_judged_gap)) return fail("max_judged_gap must be positive");
  if (!(std::isfinite(abort_hold) && abort_hold >= 0.0)) return fail("abort_hold must be >= 0");
  if (!(std::isfinite(joint_stall_rate) && joint_stall_rate >= 0.0)) return fail("joint_stall_rate must be >= 0");
  if (!(std::isfinite(tool_trim) && tool_trim >= 0.0 && tool_trim <= 0.1)) return fail("tool_trim must be in [0, 0.1] m");
  if (!(std::isfinite(setpoint_lead) && setpoint_lead <= 0.1)) {
    return fail("setpoint_lead must be at most 0.1 s (negative: half the streaming period)");
  }
  if (!positive(joint_stall_time)) return fail("joint_stall_time must be positive");
  if (!positive(innovation_gate) || !positive(innovation_acceleration)) {
    return fail("innovation_gate and innovation_acceleration must be positive");
  }
  if (std::string tracker_why; !target_tracker.IsValid(&tracker_why)) {
    if (why != nullptr) *why = "target_tracker: " + tracker_why;
    return false;
  }
  if (!positive(max_target_age) || !positive(target_plan_lead) || !positive(target_replan_threshold) ||
      !(std::isfinite(target_replan_interval) && target_replan_interval >= 0.0) || !positive(target_timeout) ||
      !positive(target_tail) || !(std::isfinite(target_correction) && target_correction >= 0.0 && target_correction <= 0.1) ||
      !positive(target_arrival_tolerance)) {
    return fail("max_target_age, target_plan_lead, target_replan_threshold, target_tail, target_timeout and "
                "target_arrival_tolerance must be positive, target_replan_interval >= 0, target_correction in "
                "[0, 0.1] m");
  }
  return true;
}

// ------------------------------------------------------------------ worker

// Runs one Plan() or Replan() at a time in its own thread; the controller
// submits a job and polls for the result, so the setpoint stream never waits.
class OnlineController::Worker {
 public:
  struct Job {
    bool replan = false;
    planner::BoundaryState start;
    std::shared_ptr<const planner::PlanResult> base;  // replans: the plan to warm-start from
    double t_from = 0.0;                              // replans: on base's clock
    double requested_at = 0.0;
    bool periodic = false;  // replans: a failure keeps the current plan (no cold fallback)
    double v_max = 0.0;     // speed limit to plan with (0: the task's)
    // Plans from rest (the first, and after a hold for the link): planned
    // at the task's limits, then slowed down to v_max (time_scale.h).
    bool from_rest = false;
    // A moving target: its predicted motion from the plan's t = 0 and the
    // placement of the task's target there (MovingSceneFor).
    std::optional<planner::TargetMotion> target_motion;
    Pose target_placement = Pose::Identity();
    // OnlineOptions::target_settle: plan to the insertion's start (no
    // insertion), or the insertion from above the target.
    bool pre_grasp = false, from_settled = false;
    // Perception: a local plan in `map` (its snapshot about the start taken
    // when the job runs; v_max applies).
    std::shared_ptr<PerceptionMap> map;
  };
  struct Done {
    bool to_local_target = false;  // a local plan to a local target
    PlanRecord record;
    std::shared_ptr<const planner::PlanResult> plan;  // set when it succeeded
    std::shared_ptr<const planner::MovingSceneModels> target;  // a moving target's prediction
  };

  Worker(const PlanningSetup& setup, bool cold_fallback)
      : setup_(setup), cold_fallback_(cold_fallback), thread_([this] { Run(); }) {}

  ~Worker() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    wake_.notify_all();
    thread_.join();
  }

  void Submit(Job job) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      job_ = std::move(job);
      busy_ = true;
    }
    wake_.notify_all();
  }

  std::optional<Done> Take() {
    std::lock_guard<std::mutex> lock(mutex_);
    std::optional<Done> done = std::move(done_);
    done_.reset();
    return done;
  }

  bool busy() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return busy_;
  }

  void WaitUntilIdle() {
    std::unique_lock<std::mutex> lock(mutex_);
    idle_.wait(lock, [this] { return !busy_; });
  }

 private:
  void Run() {
#ifdef __linux__
    // Planning must never delay the setpoint stream: on a busy machine the
    // streaming thread should win the CPU, so this thread runs 10 nice levels
    // lower (Linux gives each thread its own nice value; best effort).
    const pid_t tid = static_cast<pid_t>(syscall(SYS_gettid));
    setpriority(PRIO_PROCESS, static_cast<id_t>(tid), getpriority(PRIO_PROCESS, static_cast<id_t>(tid)) + 10);
#endif
    for (;;) {
      Job job;
      {
        std::unique_lock<std::mutex> lock(mutex_);
        wake_.wait(lock, [this] { return stop_ || job_.has_value(); });
        if (stop_) return;
        job = std::move(*job_);
        job_.reset();
      }
      Done done = Execute(job);
      {
        std::lock_guard<std::mutex> lock(mutex_);
        done_ = std::move(done);
        busy_ = false;
      }
      idle_.notify_all();
    }
  }

  Done Execute(const Job& job) const {
    Done done;
    done.record.requested_at = job.requested_at;
    done.record.replan = job.replan;
    done.record.periodic = job.periodic;
    done.record.pre_grasp = job.pre_grasp;
    done.record.from_settled = job.from_settled;
    done.record.speed_limit = job.v_max > 0.0 ? std::min(job.v_max, setup_.task->limits.v_max) : setup_.task->limits.v_max;
    if (job.map) return ExecuteLocal(job, std::move(done));
    const auto begin = std::chrono::steady_clock::now();
    // The link's speed limit, when it is lower than the task's: a plan
    // from rest is made at the task's limits and slowed down as a whole (the
    // optimiser is at its best at the speeds it was tuned for); a replan,
    // whose start is moving, is made with the lower limit. Either way the
    // post-check certifies the speed flown.
    planner::Task limited = *setup_.task;
    if (job.v_max > 0.0) limited.limits.v_max = std::min(limited.limits.v_max, job.v_max);
    // A moving target: the moving points' models for this prediction, and
    // the task's target placed and moving alike. A plan from rest is made
    // at the link's limit rather than slowed down afterwards, which would
    // move its arrival away from the target's.
    planner::PlanningScene scene = setup_.scene;
    planner::Task placed = *setup_.task;
    if (job.target_motion) {
      done.record.moving_target = true;
      auto built = setup_.context->MovingSceneFor(*job.target_motion, job.target_placement);
      done.record.prediction_ms =
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - begin).count();
      if (!built.ok()) {
        done.record.status = planner::PlanStatus::kInvalidInput;
        done.record.message = built.status().message();
        return done;
      }
      done.target = std::move(*built);
      scene.moving = &done.target->scene;
      limited.tool->position = job.target_placement * limited.tool->position;
      limited.tool->orientation = Quat(job.target_placement.linear() * limited.tool->orientation.toRotationMatrix());
      limited.tool->insertion_direction = job.target_placement.linear() * limited.tool->insertion_direction;
      limited.tool->moving->motion = *job.target_motion;
      if (job.pre_grasp) {
        limited.tool->position -= limited.tool->insertion_length * limited.tool->insertion_direction;
        limited.tool->has_insertion = false;
      }
      placed = limited;
    }
    const bool slow_down_after = job.from_rest && !job.target_motion;
    auto cold_plan = [&]() -> core::Result<planner::PlanResult> {
      planner::Task task = slow_down_after ? placed : limited;
      task.start = job.start;
      if (!planner::PlansAsGoal(task)) {
        // A mission's legs are checked against their own phases, so it is
        // planned at the link's limit instead of slowed down afterwards.
        if (setup_.context == nullptr) return core::Status::InvalidArgument("a mission needs its planning context");
        task.limits.v_max = limited.limits.v_max;
        return planner::PlanTask(*setup_.context, task, 0, setup_.plan_options, *setup_.solver,
                                 setup_.mission_phases);
      }
      core::Result<planner::PlanResult> planned = planner::Plan(scene, task, setup_.plan_options, *setup_.solver);
      if (!slow_down_after || job.v_max <= 0.0 || !planned.ok() || !planned->success) return planned;
      const double peak = planner::PeakSpeed(*planned->trajectory);
      if (peak <= job.v_max) return planned;
      done.record.slowdown = peak / job.v_max;
      return planner::SlowDown(*planned, peak / job.v_max, scene, task, setup_.plan_options);
    };
    core::Result<planner::PlanResult> result = core::Status::Internal("not run");
    if (job.replan) {
      result = planner::Replan(scene, limited, setup_.plan_options, setup_.replan_options, *setup_.solver,
                               *job.base, job.t_from, job.start);
      done.record.warm_ms =
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - begin).count();
      const bool warm_failed =
          result.ok() && !result->success && (result->status == planner::PlanStatus::kPostCheckFailed || result->status == planner::PlanStatus::kSolverFailed);
      // Plan() refuses a start inside the safety margin (it has no recovery
      // rule), so after a failed recovery a cold plan would only hide why.
      const bool recovering = result.ok() && result->post_check.recovery;
      if (recovering) {
        done.record.recovery = true;
        done.record.start_clearance = result->post_check.start_clearance_exact;
      }
      if (warm_failed && cold_fallback_ && !recovering && !job.periodic) {
        done.record.cold_fallback = true;
        result = cold_plan();
      }
    } else {
      result = cold_plan();
    }
    done.record.latency_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - begin).count();
    if (!result.ok()) {
      done.record.status = planner::PlanStatus::kInvalidInput;
      done.record.message = result.status().message();
      return done;
    }
    done.record.success = result->success;
    done.record.status = result->status;
    done.record.message = result->message;
    done.record.solve_ms = result->solve_ms;
    done.record.iterations = result->iterations;
    if (job.replan && job.periodic && result->success && result->trajectory) {
      const double left = job.base->trajectory->duration() - job.t_from;
      if (result->trajectory->duration() > setup_.replan_options.DetourLimit(left)) {
        done.record.dropped_as_slower = true;
        done.record.message = core::Format("%.2f s long for the %.2f s left of the current plan",
                                           result->trajectory->duration(), left);
        return done;
      }
    }
    // Only a plan that passed the post-check is handed over.
    if (result->success && result->trajectory) done.plan = std::make_shared<const planner::PlanResult>(std::move(*result));
    return done;
  }

  // A local plan (PerceptionSetup): certified by the local planner's own
  // post-check against the snapshot's boundary, at the link's speed limit.
  Done ExecuteLocal(const Job& job, Done done) const {
    const auto begin = std::chrono::steady_clock::now();
    const explore::LocalPlanner& planner = *setup_.perception.planner;
    const explore::LocalMapSnapshot snapshot = job.map->Snapshot(planner, job.start.position);
    core::Result<explore::LocalPlanResult> result = planner.PlanIn(snapshot, job.start, job.v_max);
    done.record.latency_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - begin).count();
    done.record.snapshot_ms = snapshot.ms;
    if (!result.ok()) {
      done.record.status = planner::PlanStatus::kInvalidInput;
      done.record.message = result.status().message();
      return done;
    }
    done.record.local_status = static_cast<int>(result->status);
    done.record.scene_points = result->scene_points;
    done.record.recovery = result->recovery;
    done.record.start_clearance = result->start_clearance;
    const bool planned = explore::IsCertified(result->status);
    done.record.message = planned ? std::string() : std::string(explore::LocalPlanStatusName(result->status)) +
                                                        (result->message.empty() ? "" : ": " + result->message);
    if (!planned) {
      done.record.status = planner::PlanStatus::kSolverFailed;
      return done;
    }
    done.record.success = true;
    done.record.status = result->plan.status;
    done.record.solve_ms = result->plan.solve_ms;
    done.record.iterations = result->plan.iterations;
    done.to_local_target = result->status == explore::LocalPlanStatus::kToLocalTarget;
    done.plan = std::make_shared<const planner::PlanResult>(std::move(result->plan));
    return done;
  }

  PlanningSetup setup_;
  bool cold_fallback_;
  mutable std::mutex mutex_;
  std::condition_variable wake_, idle_;
  std::optional<Job> job_;
  std::optional<Done> done_;
  bool busy_ = false;
  bool stop_ = false;
  std::thread thread_;  // last: starts once everything above exists
};

// -------------------------------------------------------------- controller

core::Result<std::unique_ptr<OnlineController>> OnlineController::Create(const PlanningSetup& setup,
                                                                          const OnlineOptions& options) {
  if (std::string why; !options.IsValid(&why)) return core::Status::InvalidArgument("online options: " + why);
  if (setup.task == nullptr || setup.solver == nullptr) {
    return core::Status::InvalidArgument("the planning setup needs a task and a solver");
  }
  if (std::string why; !setup.plan_options.IsValid(&why)) return core::Status::InvalidArgument("planner options: " + why);
  if (std::string why; !setup.replan_options.IsValid(&why)) return core::Status::InvalidArgument(why);
  if (!planner::PlansAsGoal(*setup.task) && planner::MovingToolGoal(*setup.task) != nullptr) {
    return core::Status::InvalidArgument(setup.task->file +
                                         ": a mission with a moving reach is planned and certified by quadhand-plan; "
                                         "the online mode does not fly one yet (docs/moving_targets.md)");
  }
  if (setup.perception.planner != nullptr) {
    if (std::string why; !setup.perception.IsValid(&why)) return core::Status::InvalidArgument("perception: " + why);
    if (!planner::PlansAsGoal(*setup.task) || setup.task->tool) {
      return core::Status::InvalidArgument(setup.task->file +
                                           ": flying on the sensor takes a goal at rest (no mission, tool pose or "
                                           "moving target yet)");
    }
  }
  if (setup.task->tool && setup.task->tool->moving && setup.context == nullptr) {
    return core::Status::InvalidArgument("a moving target needs the planning context (its moving points' models)");
  }
  return std::unique_ptr<OnlineController>(new OnlineController(setup, options));
}

OnlineController::OnlineController(const PlanningSetup& setup, const OnlineOptions& options)
    : setup_(setup),
      options_(options),
      worker_(std::make_unique<Worker>(setup, options.cold_fallback)),
      clock_(options.clock_sync),
      planned_speed_limit_(setup.task->limits.v_max),
      tool_link_(setup.scene.robot.LinkIndex(setup.task->tool_link)) {
  if (perceiving()) {
    // Options validated in Create, so the map can be made.
    map_ = std::make_shared<PerceptionMap>(setup.perception);
    gate_ = std::make_unique<perception::FrameGate>(setup.perception.gate);
  }
  if (setup.task->tool && setup.task->tool->moving) {
    tracker_ = std::make_unique<TargetTracker>(options.target_tracker);
    task_target_ = MakePose(setup.task->tool->position, setup.task->tool->orientation.toRotationMatrix());
  }
}

OnlineController::~OnlineController() = default;

bool OnlineController::planning() const { return worker_->busy(); }
void OnlineController::WaitUntilIdle() { worker_->WaitUntilIdle(); }

bool OnlineController::HaveState() const { return have_position_ && have_attitude_ && have_joints_; }

namespace {

// Plan time at which the insertion piece (the last) begins; the plan's end
// when it has none.
double InsertionStart(const planner::PlanResult& plan) {
  const planner::WholeBodyTrajectory& trajectory = *plan.trajectory;
  if (!plan.insertion.enabled) return trajectory.duration();
  const VecX& T = trajectory.position().durations();
  return trajectory.duration() - T[T.size() - 1];
}

}  // namespace

Setpoint OnlineController::HoldAtMeasuredPose() const {
  Setpoint hold;
  hold.position = position_;
  hold.yaw = traj::HopfYawOf(attitude_);
  hold.joints = joints_;
  hold.joint_rates = VecX::Zero(joints_.size());
  return hold;
}

bool OnlineController::finished() const {
  return arrival_done_ || abort_done_ || phase_ == Phase::kVehicleLost || phase_ == Phase::kHandshakeFailed;
}

// A moving target's abort: how many of the estimate's standard deviations
// the measured clearance must be under the accepted one.
constexpr double kAbortTargetSigmas = 2.0;

void OnlineController::CheckAbort(double t) {
  if (aborted_ && retreat_follows_target_) {
    // Along the plan with the target, then following it at the insertion's
    // start (RetreatReference stands there, carried with the target).
    if (!retreat_ended_noted_ && t - retreat_start_ >= retreat_duration_) {
      retreat_ended_noted_ = true;
      Event(Format("retreated to the insertion's start with the target: following it there for %.2f s",
                   retreat_hold_) +
            (retreat_hold_ < options_.abort_hold ? " (farther it would come under the safety distance less the "
                                                   "tolerance against the still scene)"
                                                 : ""));
    }
    if (t - retreat_start_ >= retreat_duration_ + retreat_hold_) abort_done_ = true;
    return;
  }
  if (aborted_) {
    if (retreating_ && t - retreat_start_ >= retreat_duration_) {
      retreating_ = false;
      phase_ = Phase::kHoldingAfterFailure;
      hold_ = HoldAt(RetreatReference(t));
      Event(Format("retreated to the insertion's start: holding there for %.1f s", options_.abort_hold));
    }
    if (joint_stalled_ && phase_ == Phase::kFlying && t - retreat_start_ >= retreat_duration_) {
      // Stopped along the plan: hold there.
      if (const std::optional<Setpoint> stop = LinkHoldReference(t)) hold_ = HoldAt(*stop);
      phase_ = Phase::kHoldingAfterFailure;
      link_hold_ = false;
      Event(Format("stopped along the plan: holding there for %.1f s", options_.abort_hold));
    }
    if (!retreating_ && t - retreat_start_ >= retreat_duration_ + options_.abort_hold) abort_done_ = true;
    return;
  }
  const bool moving = tracker_ != nullptr;
  if (!options_.abort_near_goal || IsMission() || !to_.plan || !to_.plan->insertion.enabled || link_hold_ ||
      blending_ || arrival_done_ || retreat_refused_ || !HaveState() || position_time_ <= abort_checked_time_) {
    return;
  }
  // A moving target: on the insertion's plan (and the follow after it).
  if (moving && (!to_.target || PlansToPreGrasp() || target_stage_ == TargetStage::kSettling)) return;
  if (phase_ != Phase::kFlying && phase_ != Phase::kArrived) return;
  const double insertion_start = InsertionStart(*to_.plan);
  const double plan_time = std::min(to_.plan->trajectory->duration(), t - to_.start);
  if (plan_time < insertion_start) return;
  abort_checked_time_ = position_time_;
  const double accepted = planner::AcceptedClearance(*setup_.task, options_.clearance_tolerance);
  int link = -1;
  robot::KinematicsState kinematics;
  const double reach = planner::ClearanceSearchReach(*setup_.task);
  const planner::MovingScene* points = moving && setup_.scene.moving != nullptr && setup_.scene.moving->has_points()
                                           ? setup_.scene.moving
                                           : nullptr;
  const double clearance =
      points != nullptr ? MeasuredClearance(setup_.scene.robot, setup_.scene.exact, points->exact,
                                            points->target_at_zero, TargetPoseAt(position_time_), measured(), reach,
                                            &link)
                        : MeasuredClearance(setup_.scene.robot, setup_.scene.exact, measured(), reach, &kinematics,
                                            &link);
  // Against a moving target the clearance is measured against an estimate
  // that is off by a few millimetres: only what is under by more than twice
  // its uncertainty aborts (a false abort gives up a grasp the truth would
  // have kept). The verdict (exit 6) is still the accepted clearance's.
  double abort_below = accepted;
  if (moving) {
    const std::optional<TargetEstimate> estimate = tracker_->Estimate(position_time_);
    abort_below -= kAbortTargetSigmas * (estimate ? estimate->position_sigma : 0.0);
  }
  if (clearance >= abort_below) return;
  retreat_start_ = t;
  retreat_from_ = plan_time;
  retreat_to_ = insertion_start;
  // With the target as short as the plan allows (the longer the retreat,
  // the farther the target takes the vehicle): the smoothstep clock's
  // peak rate is 1.5 / duration per second of plan, so over 1.5 times the
  // plan's span no state is run faster than it was planned.
  retreat_duration_ = moving ? std::max(0.5, 1.5 * (retreat_from_ - retreat_to_))
                             : std::max(1.0, 2.0 * (retreat_from_ - retreat_to_));
  const std::string near = Format("the vehicle is %.4f m from the scene", clearance) + " (link " +
                           (link >= 0 ? setup_.scene.robot.link(link).name : std::string("?")) +
                           Format(") on the insertion or at the goal, under the safety distance less the tolerance "
                                  "(%.4f m): ",
                                  accepted);
  if (moving) {
    // The retreat goes on with the target: first make sure that the still
    // scene leaves it room, as the target is predicted now.
    retreat_follows_target_ = true;
    if (!RetreatWithTargetIsClear(t)) {
      retreat_follows_target_ = false;
      retreat_refused_ = true;
      Event(near + "a retreat with the target would come under it against the still scene: flying on");
      return;
    }
  }
  aborted_ = true;
  retreating_ = true;
  Event(near + (moving ? "aborting, retreating along the plan with the target to the insertion's start"
                       : "aborting, retreating along the plan to the insertion's start"));
}

// How far (rad) a following joint may be from the plan beyond what the
// plan moved it within the lag: the servo's steady error and noise.
constexpr double kJointStallSlack = 0.03;
// A joint this far from the plan (rad) and slower than kStuckRate (rad/s)
// stands still off it: servo noise and a following joint's lag stay under.
constexpr double kStuckOffset = 0.01;
constexpr double kStuckRate = 0.01;
// How much older than the joint states (s) the servos' goals may be and
// still count: they come in the same telemetry, a frame apart.
constexpr double kGoalAge = 0.05;
// A servo's goal unchanged for this long (s, a few setpoint periods) while
// the plan moves the joint: no setpoint has reached the vehicle.
constexpr double kGoalStill = 0.06;
// How far from a mission's plan the autopilot's failsafe may have held the
// vehicle (base or tool, m) for OFFBOARD to fly it back there, and the
// grid of base and arm progress the move is checked on (RejoinMargin).
constexpr double kMissionRejoinDistance = 0.2;
constexpr int kRejoinGrid = 9;

int OnlineController::StuckJointAhead(double t, double at, double lag, const std::vector<std::pair<int, double>>& stuck,
                                      std::string* words) const {
  if (stuck.empty()) return -1;
  // Over the brake's path (half its duration at the plan's pace) and the
  // detection's delay (the servo window, the uplink, the debounce twice).
  const std::optional<Setpoint> reference = Reference(t);
  const double speed = reference ? reference->velocity.norm() : 0.0;
  const double brake = BrakeDuration(speed);
  const double horizon = 0.5 * brake + lag + 2.0 * options_.joint_stall_time;
  std::vector<int> joints;
  for (const auto& [k, off] : stuck) joints.push_back(k);
  double where = at;
  int link = -1;
  const double margin = PathMargin(at, at + horizon, Vec3::Zero(), joints, nullptr, &where, &link);
  if (margin >= 0.0) return -1;
  const auto farthest =
      std::max_element(stuck.begin(), stuck.end(), [](const auto& a, const auto& b) { return a.second < b.second; });
  *words = Format("; with it there, the plan %.2f s ahead comes %.4f m under the safety distance less the tolerance "
                  "(link %s)",
                  where - at, -margin,
                  link >= 0 && link < setup_.scene.robot.num_links() ? setup_.scene.robot.link(link).name.c_str() : "?");
  return farthest->first;
}

void OnlineController::CheckJointStall(double t) {
  if (options_.joint_stall_rate <= 0.0 || phase_ != Phase::kFlying || aborted_ || link_hold_ || !to_.plan ||
      !have_joints_ || joints_time_ <= stall_checked_time_) {
    return;
  }
  stall_checked_time_ = joints_time_;
  // The plan at the state's own time and before it. A servo follows its
  // command late by its lag, and the command reaches the vehicle late by
  // the uplink: within kLag plus the uplink, a joint that follows is no
  // farther from the plan than the plan moved it in that time. While a
  // replan is blended in, the window reaches back into the old plan, and
  // the reference lies between the two: a joint is off the plan only when
  // it is off both (replans come every second or so, and their blends
  // would otherwise hide a stall for half of the flight).
  const double at = joints_time_ - to_.start;
  constexpr double kLag = 0.3;
  const double lag = kLag + (clock_.synced() ? clock_.latency().uplink_max : 0.0);
  const bool old_plan = blending_ && from_.plan;
  if ((!old_plan && at - lag < 0.0) || at < 0.0 || at > to_.plan->trajectory->duration()) {
    stall_since_ = -1.0;
    return;
  }
  const auto flown = [&](double time) {
    const ActivePlan& plan = time >= to_.start || !old_plan ? to_ : from_;
    return plan.plan->trajectory->Sample(std::clamp(time - plan.start, 0.0, plan.plan->trajectory->duration()));
  };
  std::vector<planner::WholeBodySample> window;
  for (int i = 0; i <= 4; ++i) window.push_back(flown(joints_time_ - lag * i / 4.0));
  std::optional<planner::WholeBodySample> old_now;
  if (old_plan) old_now = from_.plan->trajectory->Sample(std::clamp(joints_time_ - from_.start, 0.0, from_.plan->trajectory->duration()));
  const auto off = [&](int k) {
    const double from_new = std::abs(joints_[k] - window.front().joints[k]);
    return old_now ? std::min(from_new, std::abs(joints_[k] - old_now->joints[k])) : from_new;
  };
  // A servo whose goal stands still while the plan moves it has not been
  // told to move: the setpoints stopped reaching the vehicle (a burst of
  // losses on the uplink reads as a stall of every moving joint otherwise).
  // Goals as old as the joint states, or none known: the plan alone.
  const bool goals_known = joint_goals_time_ >= joints_time_ - kGoalAge;
  const auto commanded_away = [&](int k) {
    return !goals_known || std::abs(window.front().joint_rates[k]) < kStuckRate ||
           joint_goals_time_ - goal_moved_time_[k] <= kGoalStill;
  };
  int stalled = -1;
  double planned_rate = 0.0, error = 0.0;
  for (int k = 0; k < joint_rates_.size() && stalled < 0; ++k) {
    // Stopped: the plan moved the joint fast, one way, all window long,
    // and it hardly moves.
    double least = std::numeric_limits<double>::infinity(), most = 0.0;
    const double sign = window.front().joint_rates[k] >= 0.0 ? 1.0 : -1.0;
    bool one_way = true;
    for (const planner::WholeBodySample& s : window) {
      one_way = one_way && s.joint_rates[k] * sign > 0.0;
      least = std::min(least, std::abs(s.joint_rates[k]));
      most = std::max(most, std::abs(s.joint_rates[k]));
    }
    const bool stopped =
        one_way && least >= options_.joint_stall_rate && std::abs(joint_rates_[k]) < 0.1 * least;
    // Left behind: farther from the plan than the lag explains (a joint
    // stuck while the plan moves it slowly).
    const double behind = off(k);
    if ((stopped || behind > kJointStallSlack + lag * most) && commanded_away(k)) {
      stalled = k;
      planned_rate = most;
      error = behind;
    }
  }
  // Standing still off the plan, whatever the plan's rate (a joint stuck
  // where the plan moves it slowly is left behind only slowly).
  std::string ahead;
  if (stalled < 0) {
    std::vector<std::pair<int, double>> stuck;  // joint, how far off the plan
    for (int k = 0; k < joint_rates_.size(); ++k) {
      const double still = std::max(kStuckRate, 0.2 * std::abs(window.front().joint_rates[k]));
      if (off(k) > kStuckOffset && std::abs(joint_rates_[k]) < still && commanded_away(k)) stuck.push_back({k, off(k)});
    }
    stalled = StuckJointAhead(t, at, lag, stuck, &ahead);
    if (stalled >= 0) {
      error = off(stalled);
      planned_rate = std::abs(window.front().joint_rates[stalled]);
    }
  }
  if (stalled < 0) {
    stall_since_ = -1.0;
    return;
  }
  if (stall_since_ < 0.0) stall_since_ = joints_time_;
  if (joints_time_ - stall_since_ < options_.joint_stall_time) return;
  const std::string name = setup_.scene.robot.joint(setup_.scene.robot.actuated_joints()[stalled]).name;
  // An abort without a retreat (the plan backwards needs the joint too):
  // the vehicle brakes along the plan's path as for a slow link (a hard
  // stop at the measured pose overshoots and tilts, and went into window
  // frames in the campaign), holds where it stopped for abort_hold, and
  // the flight ends (exit 7).
  const std::optional<Setpoint> reference = Reference(t);
  const double speed = reference ? reference->velocity.norm() : 0.0;
  BrakeAlongPlan(t, speed);
  hold_until_resume_ = false;
  aborted_ = true;
  joint_stalled_ = true;
  retreating_ = false;
  retreat_start_ = t;
  retreat_duration_ = link_brake_duration_;
  Event(Format("joint %s does not follow the plan: %.3f rad from it, moving at %.3f rad/s where the plan moves it "
               "at up to %.2f rad/s (for %.2f s)",
               name.c_str(), error, std::abs(joint_rates_[stalled]), planned_rate, joints_time_ - stall_since_) +
        ahead +
        Format("; the plan's clearance assumed it follows: aborting, braking along the plan over %.2f s and "
               "holding there for %.1f s",
               link_brake_duration_, options_.abort_hold));
}

Setpoint OnlineController::RetreatReference(double t) const {
  // The plan backwards from retreat_from_ to retreat_to_ on a smoothstep
  // clock: at rest at both ends, the same (certified) configurations.
  const double u = std::clamp((t - retreat_start_) / retreat_duration_, 0.0, 1.0);
  const double span = retreat_from_ - retreat_to_;
  const double tau = retreat_from_ - span * (3.0 * u * u - 2.0 * u * u * u);
  const double rate = -span * (6.0 * u - 6.0 * u * u) / retreat_duration_;
  const double rate_change = -span * (6.0 - 12.0 * u) / (retreat_duration_ * retreat_duration_);
  const planner::WholeBodySample s = to_.plan->trajectory->Sample(tau);
  Setpoint sp = FromSample(s);
  sp.velocity = s.velocity * rate;
  sp.acceleration = s.acceleration * rate * rate + s.velocity * rate_change;
  sp.yaw_rate = s.yaw_rate * rate;
  sp.joint_rates = s.joint_rates * rate;
  if (retreat_follows_target_) CarryWithTarget(t, tau, s.velocity, rate, rate_change, &sp);
  return sp;
}

void OnlineController::Event(std::string text) { events_.push_back(std::move(text)); }

void OnlineController::Fail(Phase phase, const std::string& why, HoldCause cause) {
  if (to_.plan && (phase_ == Phase::kFlying || phase_ == Phase::kArrived) && last_setpoint_) {
    failed_plan_time_ = last_setpoint_time_ - to_.start;
  }
  phase_ = phase;
  blending_ = false;
  hold_cause_ = phase == Phase::kHoldingAfterFailure ? cause : HoldCause::kNone;
  if (phase == Phase::kHoldingAfterFailure) {
    // The last setpoint streamed came from a plan that passed the post-check
    // (or is the initial hold): stay there.
    if (last_setpoint_) hold_ = HoldAt(*last_setpoint_);
    Event(why + "; holding at the last setpoint (" + Format("%.3f, ", hold_.position.x()) +
          Format("%.3f, %.3f)", hold_.position.y(), hold_.position.z()));
  } else {
    Event(why + "; streaming stopped");
  }
}

void OnlineController::OnPosition(double t, const Vec3& estimate, const Vec3& velocity, double vehicle_time) {
  if (std::isnan(vehicle_time)) vehicle_time = t;
  if (!estimate.allFinite() || !velocity.allFinite() || !std::isfinite(t)) return;
  Vec3 position = estimate - stats_.estimate_shift;
  if (have_position_ && t <= position_time_) {
    ++stats_.stale_states_dropped;  // overtaken by a newer state, or a duplicate
    return;
  }
  if (have_position_) {
    const double dt = vehicle_time - position_vehicle_time_;
    const Vec3 predicted = position_ + 0.5 * (velocity_ + velocity) * dt;
    const double explained = 0.5 * options_.innovation_acceleration * dt * dt;
    const double innovation = (position - predicted).norm();
    if (innovation > options_.innovation_gate + explained) {
      const double jump = innovation - explained;
      ++stats_.estimate_jumps;
      stats_.estimate_jump_sum += jump;
      if (jump > stats_.largest_estimate_jump) {
        stats_.largest_estimate_jump = jump;
        stats_.largest_estimate_jump_time = t;
      }
      const std::string what = Format("the position estimate jumped by %.4f m", jump) +
                               Format(" (innovation gate %.4f m over %.3f s)", options_.innovation_gate + explained, dt);
      if (options_.shift_setpoints_on_jump) {
        // The whole innovation, not only its part beyond the gate: what the
        // motion explains is at most 0.5 a dt^2 (under a millimetre at 50 Hz).
        stats_.estimate_shift += position - predicted;
        position = estimate - stats_.estimate_shift;
        Event(what + Format(": the setpoints are shifted by (%.4f, ", stats_.estimate_shift.x()) +
              Format("%.4f, %.4f) m from now on, so that the vehicle does not fly the jump; its states are ",
                     stats_.estimate_shift.y(), stats_.estimate_shift.z()) +
              "judged less that shift (if the jump was a re-localisation that corrected the estimate, the "
              "flight was that far off before it, and stays so)");
      } else {
        Event(what + ": the path flown before or after it was that far from where its states say");
      }
    }
  }
  have_position_ = true;
  position_time_ = t;
  position_vehicle_time_ = vehicle_time;
  position_ = position;
  velocity_ = velocity;
  position_checked_ = false;
  age_noted_ = false;
  ++stats_.position_measurements;
  if (phase_ != Phase::kFlying || link_hold_) return;
  const std::optional<Setpoint> reference = ReferenceFollowedAt(t);
  if (!reference) return;
  const double error = (position - reference->position).norm();
  last_error_ = error;
  last_velocity_error_ = (velocity - reference->velocity).norm();
  stats_.max_tracking_error = std::max(stats_.max_tracking_error, error);
  stats_.sum_tracking_error += error;
  stats_.sum_squared_tracking_error += error * error;
  ++stats_.tracking_samples;
}

void OnlineController::OnAttitude(double t, const Quat& attitude, const Vec3& body_rate) {
  if (!attitude.coeffs().allFinite() || !(attitude.norm() > 0.5) || !body_rate.allFinite() || !std::isfinite(t)) return;
  if (t <= attitude_time_) return;
  attitude_time_ = t;
  have_attitude_ = true;
  attitude_ = attitude.normalized();
  body_rate_ = body_rate;
}

void OnlineController::OnJoints(double t, const VecX& joints, const VecX& joint_rates) {
  const int n = setup_.scene.robot.num_actuated();
  if (joints.size() != n || joint_rates.size() != n || !joints.allFinite() || !joint_rates.allFinite() ||
      !std::isfinite(t)) {
    return;
  }
  if (t <= joints_time_) return;
  joints_time_ = t;
  have_joints_ = true;
  joints_ = joints;
  joint_rates_ = joint_rates;
}

void OnlineController::OnJointGoals(double t, const VecX& goals) {
  if (goals.size() != setup_.scene.robot.num_actuated() || !goals.allFinite() || !std::isfinite(t) ||
      t <= joint_goals_time_) {
    return;
  }
  if (joint_goals_.size() != goals.size()) {
    joint_goals_ = goals;
    goal_moved_time_ = VecX::Constant(goals.size(), t);
  }
  for (int k = 0; k < goals.size(); ++k) {
    if (goals[k] != joint_goals_[k]) goal_moved_time_[k] = t;
  }
  joint_goals_time_ = t;
  joint_goals_ = goals;
}

void OnlineController::OnTimesync(double t, int64_t tc1, int64_t ts1) {
  const bool was_synced = clock_.synced();
  if (!clock_.OnAnswer(t, tc1, ts1)) return;
  if (!was_synced && clock_.synced()) {
    const LinkLatency l = clock_.latency();
    Event(Format("clock synchronised with the vehicle (TIMESYNC round trip %.1f ms)", l.round_trip * 1e3));
  }
}

double OnlineController::MeasurementTime(double received, double vehicle_time) const {
  if (!clock_.synced()) return received;
  // An estimate's error must never make a state look younger than it can be.
  return std::min(received, clock_.ToLocal(vehicle_time));
}

double OnlineController::LinkSpeedLimit(double t) const {
  if (!clock_.synced() || !have_position_) return std::numeric_limits<double>::infinity();
  const double blind = BlindTime(t);
  if (blind <= 0.0) return std::numeric_limits<double>::infinity();
  return options_.link_budget * setup_.task->safety_distance / blind;
}

void OnlineController::OnHeartbeat(double t, bool armed, bool offboard) {
  seen_heartbeat_ = true;
  vehicle_armed_ = armed;
  vehicle_offboard_ = offboard;
  // After both were confirmed, a heartbeat without them means the vehicle
  // (or its pilot) took over. A grace period covers heartbeats sent before
  // the mode change that arrive after its acknowledgement.
  // (A plan that failed before the handshake ended holds without either.)
  const bool confirmed_phase = offboard_confirmed_ && armed_confirmed_ &&
                               (phase_ == Phase::kWaitingForPlan || phase_ == Phase::kFlying ||
                                phase_ == Phase::kArrived || phase_ == Phase::kHoldingAfterFailure);
  const double grace = options_.heartbeat_period + options_.ack_timeout + 0.5;
  if (reengaging_) return;  // the handshake in Tick watches the mode again
  // After the failsafe took the vehicle, a flight that ended holding
  // leaves it there: its mode is expected.
  if (left_offboard_in_outage_ && phase_ == Phase::kHoldingAfterFailure) return;
  // The uplink's silence around this heartbeat (and the mode change in it).
  const double answer_gap = clock_.LongestAnswerGap(t, t - options_.heartbeat_period - 1.0);
  const bool uplink_silent = answer_gap > options_.max_blind_time;
  if (confirmed_phase && armed && !offboard && phase_ == Phase::kFlying && !link_hold_ && !aborted_ && uplink_silent) {
    // It left OFFBOARD while our TIMESYNC requests went unanswered, and the
    // states kept coming: the uplink was down, no setpoint reached it, and
    // its offboard-loss failsafe took over. Held as a link hold, and
    // re-engaged once both directions work.
    const std::optional<Setpoint> reference = Reference(t);
    HoldForLink(t, reference ? reference->velocity.norm() : 0.0);
    left_offboard_in_outage_ = true;
    Event(Format("the autopilot left OFFBOARD while no TIMESYNC answer came for %.2f s: the uplink is down and its ",
                 answer_gap) +
          "offboard-loss failsafe holds the vehicle; OFFBOARD will be requested again once the link is good");
    return;
  }
  if (confirmed_phase && armed && !offboard && aborted_ && (left_offboard_in_outage_ || uplink_silent)) {
    // An abort (a joint that stopped following: in an uplink outage every
    // joint stands at its last setpoint, so the outage can read as a stall)
    // during which the uplink went silent: the failsafe's hold, not a
    // refusal. The abort's outcome stands.
    if (!left_offboard_in_outage_) {
      Event("the autopilot left OFFBOARD while no TIMESYNC answer came: the uplink is down and its offboard-loss "
            "failsafe holds the vehicle");
    }
    left_offboard_in_outage_ = true;
    return;
  }
  if (confirmed_phase && armed && !offboard && phase_ == Phase::kFlying && link_hold_ && !aborted_) {
    // Its offboard-loss failsafe (PX4: COM_OF_LOSS_T, then hold): the
    // vehicle holds on its own; it is re-engaged once the link is good.
    if (!left_offboard_in_outage_) {
      Event("the autopilot left OFFBOARD during the link hold (its offboard-loss failsafe): it holds where it "
            "is; OFFBOARD will be requested again once the link is good");
    }
    left_offboard_in_outage_ = true;
    return;
  }
  if (confirmed_phase && (!armed || !offboard) && t - confirmed_time_ > grace && !arrival_done_) {
    Fail(Phase::kHandshakeFailed, std::string("the vehicle left ") + (!offboard ? "OFFBOARD" : "the armed state"));
  }
}

void OnlineController::OnAutopilotMode(double t, AutopilotMode mode, bool armed) {
  (void)t;
  if (mode == autopilot_mode_) return;
  const bool first = autopilot_mode_ == AutopilotMode::kUnknown;
  autopilot_mode_ = mode;
  if (first) return;
  std::string text = std::string("the autopilot is now in ") + AutopilotModeName(mode) + (armed ? "" : " (disarmed)");
  if (mode == AutopilotMode::kLand) text += ": it is landing (its failsafe, or its pilot)";
  Event(text);
}

void OnlineController::OnCommandAck(double t, Command command, AckResult result) {
  (void)t;
  if (command == Command::kGripper) {
    if (gripper_pending_ < 0) return;
    const std::string step = planner::StepName(setup_.task->mission, static_cast<size_t>(gripper_pending_));
    if (result == AckResult::kAccepted) {
      Event("gripper command of " + step + " accepted");
      gripper_pending_ = -1;
    } else if (result == AckResult::kRejected) {
      gripper_pending_ = -1;
      Fail(Phase::kHoldingAfterFailure, "the vehicle refused the gripper command of " + step, HoldCause::kGripperFailed);
    }
    return;
  }
  const bool expected = ((phase_ == Phase::kRequestingOffboard || reengaging_) && command == Command::kSetOffboardMode) ||
                        (phase_ == Phase::kArming && command == Command::kArm);
  if (!expected) return;
  const char* name = command == Command::kSetOffboardMode ? "OFFBOARD" : "arming";
  switch (result) {
    case AckResult::kAccepted:
      if (command == Command::kSetOffboardMode) offboard_confirmed_ = true;
      else armed_confirmed_ = true;
      Event(std::string(name) + " accepted");
      break;
    case AckResult::kTemporarilyRejected:
      Event(std::string(name) + " temporarily rejected; retrying");
      break;
    case AckResult::kRejected:
      Fail(Phase::kHandshakeFailed, std::string("the vehicle refused ") + name);
      break;
  }
}

MeasuredState OnlineController::measured() const {
  MeasuredState m;
  m.time = position_time_;
  m.position = position_;
  m.velocity = velocity_;
  m.attitude = attitude_;
  m.body_rate = body_rate_;
  m.joints = joints_;
  m.joint_rates = joint_rates_;
  return m;
}

planner::BoundaryState OnlineController::MeasuredBoundaryState() const {
  planner::BoundaryState s;
  s.position = position_;
  s.velocity = velocity_;
  s.yaw = traj::HopfYawOf(attitude_);
  s.yaw_rate = traj::HopfYawRateOf(attitude_, body_rate_);
  s.joints = joints_;
  s.joint_rates = joint_rates_;
  return s;
}

void OnlineController::MaybeReplan(double t, bool periodic, double error) {
  // A moving target's tail replan waiting for its splice does not hold a
  // replan from the measured state back: that one starts from the plan
  // flown now and replaces the tail.
  const bool tail_pending = PendingTailSplice(t);
  if (!options_.replanning || phase_ != Phase::kFlying || link_hold_ || (blending_ && !tail_pending) ||
      replan_pending_ || !to_.plan || aborted_ || target_stage_ == TargetStage::kSettling) {
    return;
  }
  const ActivePlan& flown = tail_pending ? from_ : to_;
  if (!periodic && t - last_trigger_ < options_.min_replan_interval) return;
  // The start is the newest state predicted over its age and the lead: not
  // from a state too old to predict from (a slow or lossy link).
  const double age = t - position_time_ + clock_.latency().uncertainty;
  if (age > options_.max_state_age) {
    ++stats_.replans_skipped_stale;
    last_trigger_ = t;
    Event(Format("%s replan not started: the newest state is %.0f ms old (limit %.0f ms)",
                 periodic ? "periodic" : "tracking-error", age * 1e3, options_.max_state_age * 1e3));
    return;
  }
  const planner::WholeBodyTrajectory& trajectory = *flown.plan->trajectory;
  const double t_splice = t + options_.replan_lead;
  const double plan_time = t_splice - flown.start;
  if (perceiving()) {
    if (periodic && (!flown.to_local_target || tail_pending)) return;
    RequestLocalReplan(t, periodic, error);
    return;
  }
  // Not in (or right before) the insertion piece: Replan would refuse. A
  // moving target's insertion is replanned as one that has begun, while a
  // piece's worth of it is left.
  if (tracker_ != nullptr) {
    if (plan_time >= trajectory.duration() - setup_.replan_options.min_piece_duration) return;
  } else if (plan_time >= InsertionStart(*flown.plan) - setup_.replan_options.min_piece_duration) {
    return;
  }
  Worker::Job job;
  if (tracker_ != nullptr && !PredictTarget(t_splice, &job.target_motion, &job.target_placement)) return;

  job.replan = true;
  job.base = flown.plan;
  job.t_from = plan_time;
  job.requested_at = t;
  job.periodic = periodic;
  job.v_max = planned_speed_limit_;
  job.start = PredictedMeasuredState(flown, plan_time);
  job.pre_grasp = PlansToPreGrasp();
  worker_->Submit(std::move(job));
  MarkReplanPending(t_splice, /*exact=*/false, /*keep_from=*/tail_pending);
  last_trigger_ = t;
  if (periodic) {
    ++stats_.periodic_replans;
    Event(Format("periodic replan (tracking error %.3f m)", error));
  } else {
    Event(Format("tracking error %.3f m > %.3f m: replanning from the measured state", error, options_.replan_threshold));
  }
}

planner::BoundaryState OnlineController::PredictedMeasuredState(const ActivePlan& flown, double plan_time) const {
  // The tracking error is held constant: it is against the reference the
  // vehicle was following when it measured the state (streamed an uplink
  // latency before), and the new plan's setpoints reach it as late as the
  // current plan's did.
  const planner::WholeBodyTrajectory& trajectory = *flown.plan->trajectory;
  const double followed = position_time_ - UplinkLatency();
  const planner::WholeBodySample now = trajectory.Sample(std::clamp(followed - flown.start, 0.0, trajectory.duration()));
  const planner::WholeBodySample then = trajectory.Sample(std::min(plan_time, trajectory.duration()));
  const planner::BoundaryState measured = MeasuredBoundaryState();
  planner::BoundaryState s = then.State();
  s.position = measured.position + (then.position - now.position);
  s.velocity = measured.velocity + (then.velocity - now.velocity);
  s.yaw = measured.yaw + (then.yaw - now.yaw);
  s.joints = measured.joints + (then.joints - now.joints);
  return s;
}

planner::BoundaryState OnlineController::MeasuredStateAtRest() const {
  planner::BoundaryState s = MeasuredBoundaryState();
  s.velocity.setZero();
  s.yaw_rate = 0.0;
  s.joint_rates.setZero();
  return s;
}

void OnlineController::MarkReplanPending(double splice_time, bool exact, bool keep_from) {
  replan_pending_ = true;
  pending_resume_ = false;
  pending_splice_time_ = splice_time;
  pending_exact_ = exact;
  pending_keep_from_ = keep_from;
  ++stats_.replans_triggered;
}

void OnlineController::RequestLocalReplan(double t, bool exact, double error) {
  // A local plan from the flown plan's own state (exact: spliced there), or
  // from the measured state predicted (off track: blended).
  if (worker_->busy()) return;
  const ActivePlan& flown = to_;
  const planner::WholeBodyTrajectory& trajectory = *flown.plan->trajectory;
  const double t_splice = t + options_.replan_lead;
  const double plan_time = t_splice - flown.start;
  Worker::Job job;
  job.start = exact ? trajectory.Sample(std::min(plan_time, trajectory.duration())).State()
                    : PredictedMeasuredState(flown, plan_time);
  job.map = map_;
  job.replan = true;
  job.requested_at = t;
  job.periodic = true;  // a failure keeps the flown plan (certified, ending at rest)
  job.v_max = planned_speed_limit_;
  blocked_since_asked_.clear();
  last_local_request_ = t;
  worker_->Submit(std::move(job));
  MarkReplanPending(t_splice, exact, /*keep_from=*/false);
  last_trigger_ = t;
  if (exact) {
    ++stats_.periodic_replans;
  } else {
    Event(Format("tracking error %.3f m > %.3f m: a local plan from the measured state", error,
                 options_.replan_threshold));
  }
}

// A moving target's (controller_target.cc has the rest): here, as it makes a
// worker's job.
void OnlineController::ReplanTail(double t, double shift) {
  const bool tail_pending = PendingTailSplice(t);
  if (!options_.replanning || phase_ != Phase::kFlying || link_hold_ || (blending_ && !tail_pending) ||
      replan_pending_ || !to_.plan || !to_.target || aborted_ || target_stage_ == TargetStage::kSettling) {
    return;
  }
  // Once the shift has begun (the insertion is near), it corrects the
  // prediction: a replan this late seldom keeps the tool on the moved line
  // (Replan's begun insertion), and each one reshapes the last approach.
  if (correction_start_ >= 0.0) return;
  // Nor in the last second: a tail that short mostly moves the arrival on.
  if (to_.start + to_.plan->trajectory->duration() - t < kLastTailReplan) return;
  const planner::WholeBodyTrajectory& trajectory = *to_.plan->trajectory;
  // A tail waiting for its splice is replaced from the same junction (the
  // plan flown until then is not the tail's); the splice must not be due
  // before the new one can be ready.
  double from = to_.start;
  if (tail_pending) {
    if (to_.start < t + options_.replan_lead) return;
  } else {
    from = std::max(t + options_.replan_lead, to_.start + trajectory.duration() - options_.target_tail);
  }
  const double plan_time = from - to_.start;
  if (trajectory.duration() - plan_time < setup_.replan_options.min_piece_duration) return;
  Worker::Job job;
  if (!PredictTarget(from, &job.target_motion, &job.target_placement)) return;
  job.start = trajectory.Sample(plan_time).State();
  job.replan = true;
  job.base = to_.plan;
  job.t_from = plan_time;
  job.requested_at = t;
  job.periodic = true;  // a failure keeps the plan
  job.v_max = planned_speed_limit_;
  job.pre_grasp = PlansToPreGrasp();
  worker_->Submit(std::move(job));
  MarkReplanPending(from, /*exact=*/true, /*keep_from=*/tail_pending);
  last_target_trigger_ = t;
  ++stats_.target_replans;
  Event(Format("the target's prediction moved the grasp %.4f m: replanning the plan from t = %.2f s", shift, from));
}

// TargetCorrection blends its shift in over this long before the insertion.
constexpr double kCorrectionRamp = 0.5;

void OnlineController::TargetCorrection(double t, Vec3* position, Vec3* velocity) {
  position->setZero();
  velocity->setZero();
  // The plan flown at t (a tail or the insertion may wait for its splice).
  const ActivePlan& active = blending_ && t < blend_start_ ? from_ : to_;
  if (tracker_ == nullptr || options_.target_correction <= 0.0 || !active.plan || !active.target || retreating_) return;
  const planner::PlanResult& plan = *active.plan;
  const double plan_time = t - active.start;
  // The ramp starts once for the flight: a replan down the insertion has
  // its own (shorter) last piece, and the shift must not go out and in again.
  if (correction_start_ < 0.0) {
    if (plan_time <= InsertionStart(plan) - kCorrectionRamp) return;
    correction_start_ = t;
  }
  const double ramp_start = plan_time - (t - correction_start_);
  const std::optional<TargetEstimate> estimate = tracker_->Estimate(t);
  if (!estimate) return;
  if (correction_plan_ != &plan) {
    // What the still scene leaves over the accepted clearance, from the
    // ramp's start to the end of the follow: the most the shift may be.
    correction_plan_ = &plan;
    // (A plan to the insertion's start is followed while settling.)
    const double follow = target_stage_ == TargetStage::kInsertion || !SettlesFirst()
                              ? options_.arrival_hold
                              : std::max(options_.arrival_hold, options_.target_settle_timeout + options_.target_plan_lead);
    const double follow_end = plan.trajectory->duration() + follow;
    double margin = PathMargin(std::max(0.0, ramp_start), plan.trajectory->duration(), Vec3::Zero(), {}, nullptr,
                               nullptr, nullptr);
    for (double tau = plan.trajectory->duration(); tau <= follow_end + 1e-9; tau += 0.05) {
      int link = -1;
      margin = std::min(margin, ConfigurationMargin(nullptr, FollowState(active, tau), &link));
    }
    correction_bound_ = std::clamp(margin, 0.0, options_.target_correction);
  }
  const Vec3 planned = PlannedTarget(active, plan_time).translation();
  Vec3 shift = estimate->position - planned;
  Vec3 rate = estimate->velocity - active.target->motion.PointVelocity(planned, plan_time);
  if (shift.norm() > correction_bound_) {
    shift *= correction_bound_ / shift.norm();
    rate.setZero();
  }
  const double weight = SpliceWeight((plan_time - ramp_start) / kCorrectionRamp);
  *position = weight * shift;
  *velocity = weight * rate;
}

void OnlineController::Settle(double t) {
  if (settle_plan_requested_ || worker_->busy() || !HaveState()) return;
  const std::optional<TargetEstimate> estimate = tracker_->Estimate(position_time_);
  if (!estimate) return;
  // The insertion's start as the target now stands, and the measured tool.
  const planner::ToolGoal& goal = *setup_.task->tool;
  const Vec3 start_in_task = goal.position - goal.insertion_length * goal.insertion_direction;
  const Vec3 wanted = TargetPoseOf(*estimate) * (task_target_.inverse() * start_in_task);
  const double off = (MeasuredTool() - wanted).norm();
  const double relative_speed = (velocity_ - estimate->velocity).norm();
  const bool settled = off <= options_.target_settle_tolerance && relative_speed <= kSettledRelativeSpeed;
  if (!settled && t - settle_start_ < settle_limit_) return;
  // The insertion from the state the follow will have at its start (the
  // shift included): the vehicle is there, moving with the target.
  Worker::Job job;
  prediction_zero_ = t + options_.target_plan_lead;
  if (!PredictTarget(prediction_zero_, &job.target_motion, &job.target_placement)) return;
  Vec3 shift, rate;
  TargetCorrection(prediction_zero_, &shift, &rate);
  const Setpoint follow = SampleActive(to_, prediction_zero_);
  job.start.position = follow.position + shift;
  job.start.velocity = follow.velocity + rate;
  job.start.yaw = follow.yaw;
  job.start.yaw_rate = follow.yaw_rate;
  job.start.joints = follow.joints;
  job.start.joint_rates = VecX::Zero(follow.joints.size());
  job.requested_at = t;
  job.v_max = planned_speed_limit_;
  job.from_settled = true;
  worker_->Submit(std::move(job));
  settle_plan_requested_ = true;
  Event(settled ? Format("settled above the target (tool %.4f m off, %.3f m/s relative): planning the insertion",
                         off, relative_speed)
                : Format("not settled above the target after %.1f s (tool %.4f m off, %.3f m/s relative): planning "
                         "the insertion anyway",
                         t - settle_start_, off, relative_speed));
}

void OnlineController::CollectPlan(double t) {
  std::optional<Worker::Done> done = worker_->Take();
  if (!done) return;
  stats_.plans.push_back(done->record);
  const PlanRecord& record = done->record;
  if (!record.replan && pending_resume_) {
    pending_resume_ = false;
    if (phase_ != Phase::kFlying) return;
    if (perceiving() && done->plan && CrossesSeenSinceAsked(*done->plan)) {
      ++stats_.perception.conflicts;
      Event("the fresh plan crosses obstacles seen since it was asked: dropped, holding");
      return;
    }
    if (!done->plan && perceiving()) {
      // The hold goes on; CheckSensor asks again from a newer map.
      Event(FailedPlanWords("no fresh plan from what the sensor has seen", record) + "; holding");
      return;
    }
    if (!done->plan) {
      Fail(Phase::kHoldingAfterFailure,
           FailedPlanWords("the plan to resume after the link hold failed", record),
           HoldCause::kPlanFailed);
      return;
    }
    to_ = {done->plan, done->target ? prediction_zero_ : t, done->target, done->to_local_target};
    const bool after_sensor_hold = perception_hold_;
    perception_hold_ = false;
    last_progress_ = t;
    from_ = ActivePlan{};
    blending_ = false;
    link_hold_ = false;
    hold_until_resume_ = false;
    planned_speed_limit_ = record.speed_limit;
    last_trigger_ = t;
    if (after_sensor_hold) {
      Event(Format("flying a fresh local plan from the measured state (%.2f s long, at most %.2f m/s, planned in "
                   "%.1f ms)",
                   done->plan->trajectory->duration(), record.speed_limit, record.latency_ms));
      return;
    }
    ++stats_.link_resumes;
    Event(Format("link good again: flying a fresh plan from the measured state (%.2f s long, ",
                 done->plan->trajectory->duration()) +
          Format("slowed down %.2fx to %.2f m/s, planned in %.1f ms)", record.slowdown, record.speed_limit,
                 record.latency_ms));
    return;
  }
  if (!record.replan && record.from_settled) {
    settle_plan_requested_ = false;
    if (phase_ != Phase::kFlying || target_stage_ != TargetStage::kSettling) return;
    if (!done->plan) {
      Fail(Phase::kHoldingAfterFailure,
           FailedPlanWords("the insertion from above the target failed", record),
           HoldCause::kPlanFailed);
      return;
    }
    if (t > prediction_zero_ + kLatestTargetStart) {
      Event(Format("the insertion's plan came %.0f ms after its start: planning it again",
                   1e3 * (t - prediction_zero_)));
      return;
    }
    // The follow until the insertion's start, which begins where it is then.
    from_ = to_;
    to_ = {done->plan, prediction_zero_, done->target};
    blending_ = true;
    blend_start_ = prediction_zero_;
    splice_window_ = 0.0;
    target_stage_ = TargetStage::kInsertion;
    Event(Format("settled above the target: the insertion's plan (%.2f s, planned in %.1f ms) starts at t = %.2f s",
                 done->plan->trajectory->duration(), record.latency_ms, prediction_zero_));
    return;
  }
  if (!record.replan) {
    if (perceiving() && (!done->plan || CrossesSeenSinceAsked(*done->plan))) {
      // Asked again from a newer map (RequestFirstPlan), until stuck_time.
      first_plan_requested_ = false;
      if (done->plan) ++stats_.perception.conflicts;
      Event(done->plan ? std::string("the first plan crosses obstacles seen since it was asked: planning again")
                       : FailedPlanWords("no first plan from what the sensor has seen", record) + "; trying again");
      return;
    }
    first_local_ = done->to_local_target;
    if (!done->plan) {
      Fail(Phase::kHoldingAfterFailure,
           FailedPlanWords("the plan failed", record),
           HoldCause::kPlanFailed);
      return;
    }
    first_plan_ = done->plan;
    first_target_ = done->target;
    planned_speed_limit_ = record.speed_limit;
    Event(Format("plan ready: %.2f s long, ", first_plan_->trajectory->duration()) +
          Format("planned in %.1f ms", record.latency_ms) +
          (record.slowdown > 1.0
               ? Format(" (slowed down %.2fx to %.2f m/s for the link's latency)", record.slowdown, record.speed_limit)
               : std::string()));
    return;
  }
  replan_pending_ = false;
  if (phase_ != Phase::kFlying) return;  // arrived or failed meanwhile: nothing to splice into
  if (link_hold_) return;  // braking for the link: a fresh plan follows when it is good again
  if (done->plan && perceiving() && CrossesSeenSinceAsked(*done->plan)) {
    ++stats_.perception.conflicts;
    Event("the new local plan crosses obstacles seen since it was asked: dropped");
  } else if (done->plan && perceiving() && pending_exact_ && t > pending_splice_time_) {
    // It starts on the flown plan's state at the splice, which is past:
    // a blend between the two would be certified by neither.
    ++stats_.perception.late_plans;
    Event(Format("the local plan came %.0f ms after its start: dropped", 1e3 * (t - pending_splice_time_)));
  } else if (done->plan) {
    planned_speed_limit_ = record.speed_limit;
    // A tail replan starts on the plan itself: spliced at its start with
    // no blend, unless it came too late for that.
    const bool late = t > pending_splice_time_;
    if (!pending_keep_from_) from_ = to_;
    to_ = {done->plan, pending_splice_time_, done->target, done->to_local_target};
    if (perceiving()) last_progress_ = t;
    blending_ = true;
    blend_start_ = std::max(t, pending_splice_time_);
    splice_window_ = pending_exact_ && !late ? 0.0 : options_.blend_window;
    ++stats_.splices;
    Event(Format(record.cold_fallback ? "replanned in %.1f ms (the warm start failed the post-check: planned cold); "
                                        "blending the new plan in from t = %.2f s"
                                      : "replanned in %.1f ms; blending the new plan in from t = %.2f s",
                 record.latency_ms, blend_start_) +
          (!record.recovery ? std::string()
           : record.local_status >= 0
               ? Format(" (backing away: %.4f m from the map's boundary, inside the certificate's floor)",
                        record.start_clearance)
               : Format(" (recovering from %.4f m inside the safety distance)",
                        setup_.task->safety_distance - record.start_clearance)));
  } else if (record.status == planner::PlanStatus::kInsertionInProgress) {
    Event("not replanned: the insertion has begun");
  } else if (record.dropped_as_slower) {
    Event("the periodic replan was certified but " + record.message + ": dropped, flying on with the current plan");
  } else if (record.periodic) {
    // On track when it started: the current plan is still certified.
    Event(FailedPlanWords("the periodic replan failed", record) + "; flying on with the current plan");
  } else {
    Fail(Phase::kHoldingAfterFailure,
         FailedPlanWords("the replan failed", record),
         HoldCause::kPlanFailed);
  }
}

std::optional<Setpoint> OnlineController::Reference(double t) const {
  if (!to_.plan) return std::nullopt;
  auto sample = [t](const ActivePlan& p) { return SampleActive(p, t); };
  if (blending_) {
    if (t < blend_start_) return sample(from_);
    const double s = splice_window_ > 0.0 ? (t - blend_start_) / splice_window_ : 1.0;
    if (s < 1.0) return Blend(sample(from_), sample(to_), SpliceWeight(s));
  }
  return sample(to_);
}

double OnlineController::UplinkLatency() const { return clock_.synced() ? clock_.latency().uplink : 0.0; }

// Each setpoint is sampled SetpointLead() ahead of its sending, and flown
// from an uplink's latency after it.
std::optional<Setpoint> OnlineController::ReferenceFollowedAt(double t) const {
  return Reference(t - UplinkLatency() + SetpointLead());
}

double OnlineController::SetpointLead() const {
  if (options_.setpoint_lead >= 0.0) return options_.setpoint_lead;
  // Half the period only: leading by the uplink's latency too would put a
  // slow link's setpoints where the vehicle is not yet, and its braking
  // (LinkHoldReference) starts from where it is. Capped: a stalled stream
  // is no streaming period.
  constexpr double kLongestLead = 0.05;
  return std::min(kLongestLead, 0.5 * streaming_period_);
}

double OnlineController::BlindTime(double t) const {
  const LinkLatency l = clock_.latency();
  // The clock's offset error adds to the age and takes as much from the
  // uplink: their sum needs no allowance for it.
  return std::max(0.0, t - position_time_) + l.uplink;
}

double OnlineController::PlanningSpeedLimit() const {
  double blind = 0.0;
  for (const auto& [time, b] : blind_history_) blind = std::max(blind, b);
  const double task_limit = setup_.task->limits.v_max;
  if (!clock_.synced() || blind <= 0.0) return task_limit;
  // A margin under what the link allows, so that ordinary jitter does not
  // brake the plan it was made for.
  return std::min(task_limit, kLinkPlanningShare * options_.link_budget * setup_.task->safety_distance / blind);
}

void OnlineController::CheckLink(double t, ControllerOutput* out) {
  if (!clock_.synced() || !have_position_) return;
  const double blind = BlindTime(t);
  blind_history_.emplace_back(t, blind);
  while (!blind_history_.empty() && blind_history_.front().first < t - options_.clock_sync.window) {
    blind_history_.pop_front();
  }
  if (phase_ != Phase::kFlying || aborted_) return;  // a retreat is not braked along the plan forwards
  const double allowed = LinkSpeedLimit(t);
  if (!link_hold_) {
    const std::optional<Setpoint> reference = Reference(t);
    const double speed = reference ? reference->velocity.norm() : 0.0;
    if (speed <= kLinkHoldSlack * allowed && blind <= options_.max_blind_time) return;
    HoldForLink(t, speed);
    Event(Format("link too slow for the speed: %.2f m/s planned, %.2f m/s allowed ", speed, allowed) +
          Format("(blind for %.0f ms: the newest state's age and the uplink): braking along the plan and holding "
                 "until the link is good",
                 blind * 1e3));
    return;
  }
  // Holding: resume with a fresh plan from the measured state once the link
  // has stayed good enough for a useful speed over the whole window. A
  // mission is not planned again from the middle of its steps: it resumes
  // along its own plan.
  if (IsMission()) {
    HoldMission(t, out);
    return;
  }
  // A brake for the sensor resumes in CheckSensor; so does one for the
  // link while the sensor is silent.
  if (perception_hold_ || (perceiving() && SensorSilent(t))) return;
  if (pending_resume_ || replan_pending_ || worker_->busy()) return;
  if (t - link_hold_start_ < link_brake_duration_ + options_.clock_sync.window) return;
  if (!LinkGoodOverWindow(t)) return;
  const double limit = PlanningSpeedLimit();
  if (limit < options_.min_link_speed) return;
  // It plans from rest at the measured pose: the vehicle must be holding.
  if (velocity_.norm() > kRestSpeed) return;
  outage_noted_ = false;
  if (left_offboard_in_outage_ && !reengaging_) {
    // OFFBOARD first, at the pose the autopilot holds: hold setpoints there
    // (nothing moves the vehicle), the request, then the fresh plan.
    StartReengagement(t);
    hold_ = HoldAtMeasuredPose();
    hold_until_resume_ = true;
    Event(Format("link good again (%.2f m/s allowed): streaming a hold at the measured pose, then requesting "
                 "OFFBOARD again",
                 limit));
    return;
  }
  if (reengaging_ && !ReengageOffboard(t, out)) return;
  Worker::Job job;
  job.start = MeasuredStateAtRest();
  job.requested_at = t;
  job.v_max = limit;
  job.from_rest = true;
  if (tracker_ != nullptr) {
    // Against the prediction from a t = 0 fixed now (the plan is held there until then).
    prediction_zero_ = t + options_.target_plan_lead;
    if (!PredictTarget(prediction_zero_, &job.target_motion, &job.target_placement)) return;
  }
  job.pre_grasp = PlansToPreGrasp();
  if (perceiving()) {
    job.map = map_;
    blocked_since_asked_.clear();
    last_local_request_ = t;
  }
  worker_->Submit(std::move(job));
  pending_resume_ = true;
  Event(Format("link good again (%.2f m/s allowed): planning afresh from the measured state", limit));
}

void OnlineController::RequestFreshLocalPlan(double t) {
  // It plans from rest at the measured pose: the vehicle must be holding.
  if (velocity_.norm() > kRestSpeed) return;
  Worker::Job job;
  job.start = MeasuredStateAtRest();
  job.requested_at = t;
  job.v_max = PlanningSpeedLimit();
  job.from_rest = true;
  job.map = map_;
  blocked_since_asked_.clear();
  last_local_request_ = t;
  worker_->Submit(std::move(job));
  pending_resume_ = true;
}

void OnlineController::HoldForLink(double t, double speed) {
  BrakeAlongPlan(t, speed);
  if (IsMission()) StartMissionHold(t);
  ++stats_.link_holds;
}

double OnlineController::BrakeDuration(double speed) const {
  return std::max(0.2, 2.0 * speed / (0.5 * setup_.task->limits.a_max));
}

void OnlineController::BrakeAlongPlan(double t, double speed) {
  // The current plan's clock slows to a stop (LinkHoldReference): the same
  // path, at half the task's acceleration limit on average.
  link_hold_ = true;
  link_hold_start_ = t;
  link_brake_duration_ = BrakeDuration(speed);
}

double OnlineController::RejoinMargin(double plan_time) const {
  const planner::MissionLeg* leg = nullptr;
  for (const planner::MissionLeg& l : to_.plan->mission_legs) {
    if (plan_time >= l.start_s && plan_time <= l.end_s) {
      leg = &l;
      break;
    }
  }
  if (leg == nullptr || leg->robot == nullptr || leg->robot_exact == nullptr) return -1.0;
  const planner::WholeBodySample to = to_.plan->trajectory->Sample(plan_time);
  const Quat to_attitude(to.BasePose().rotation());
  double margin = std::numeric_limits<double>::infinity();
  MeasuredState m = measured();
  for (int i = 0; i < kRejoinGrid; ++i) {
    const double base = static_cast<double>(i) / (kRejoinGrid - 1);
    for (int k = 0; k < kRejoinGrid; ++k) {
      const double arm = static_cast<double>(k) / (kRejoinGrid - 1);
      m.position = position_ + base * (to.position + tool_trim_ - position_);
      m.attitude = attitude_.slerp(base, to_attitude);
      m.joints = joints_ + arm * (to.joints - joints_);
      int link = -1;
      margin = std::min(margin, ConfigurationMargin(plan_time, m, &link));
    }
  }
  return margin;
}

double OnlineController::ConfigurationMargin(double plan_time, const MeasuredState& state, int* link) const {
  const planner::MissionLeg* leg = nullptr;
  for (const planner::MissionLeg& l : to_.plan->mission_legs) {
    if (plan_time >= l.start_s && plan_time <= l.end_s) {
      leg = &l;
      break;
    }
  }
  return ConfigurationMargin(leg, state, link);
}

double OnlineController::ConfigurationMargin(const planner::MissionLeg* leg, const MeasuredState& state,
                                             int* link) const {
  const double accepted = planner::AcceptedClearance(*setup_.task, options_.clearance_tolerance);
  const double reach = planner::ClearanceSearchReach(*setup_.task);
  robot::KinematicsState kinematics;
  if (leg == nullptr || leg->robot == nullptr || leg->robot_exact == nullptr) {
    return MeasuredClearance(setup_.scene.robot, setup_.scene.exact, state, reach, &kinematics, link) - accepted;
  }
  double margin = MeasuredClearance(*leg->robot, *leg->robot_exact, state, reach, &kinematics, link) - accepted;
  if (leg->object_exact != nullptr && leg->object_link >= 0) {
    margin = std::min(margin, leg->object_exact->LinkClearance(leg->object_link,
                                                               kinematics.link_poses[leg->object_link], reach, {}) -
                                  (leg->object_clearance - options_.clearance_tolerance));
  }
  return margin;
}

double OnlineController::PathMargin(double from, double to, const Vec3& shift, const std::vector<int>& held,
                                    const planner::MissionLeg* leg, double* at, int* link) const {
  // Samples 2 cm of the base's path apart at most (and 0.05 s): far finer
  // than the margins a stall or a trim eats into.
  const planner::WholeBodyTrajectory& plan = *to_.plan->trajectory;
  to = std::min(to, plan.duration());
  double margin = std::numeric_limits<double>::infinity();
  MeasuredState m = measured();
  for (double tau = from;;) {
    const planner::WholeBodySample s = plan.Sample(tau);
    m.position = s.position + shift;
    m.attitude = Quat(s.BasePose().rotation());
    m.joints = s.joints;
    for (int k : held) m.joints[k] = joints_[k];
    int nearest = -1;
    const double here = leg != nullptr ? ConfigurationMargin(leg, m, &nearest) : ConfigurationMargin(tau, m, &nearest);
    if (here < margin) {
      margin = here;
      if (at != nullptr) *at = tau;
      if (link != nullptr) *link = nearest;
    }
    if (tau >= to) break;
    tau = std::min(to, tau + std::clamp(0.02 / std::max(s.velocity.norm(), 1e-3), 0.005, 0.05));
  }
  return margin;
}

void OnlineController::StartReengagement(double t) {
  reengaging_ = true;
  ++stats_.reengagements;
  hold_start_ = t;
  offboard_confirmed_ = false;
  attempts_ = 0;
}

bool OnlineController::ReengageOffboard(double t, ControllerOutput* out) {
  // The autopilot accepts OFFBOARD only after a stream of setpoints.
  if (t - hold_start_ < options_.hold_time) return false;
  if (vehicle_offboard_ && seen_heartbeat_) offboard_confirmed_ = true;
  if (!CommandUntilConfirmed(t, Command::kSetOffboardMode, offboard_confirmed_, "OFFBOARD after the outage", out)) {
    return false;
  }
  confirmed_time_ = t;
  reengaging_ = false;
  left_offboard_in_outage_ = false;
  Event("offboard again");
  return true;
}

bool OnlineController::LinkGoodOverWindow(double t) const {
  const double since = t - options_.clock_sync.window;
  for (const auto& [time, b] : blind_history_) {
    if (time >= since && b > options_.max_blind_time) return false;
  }
  // The states say the downlink works; only answers say the uplink does.
  return clock_.LongestAnswerGap(t, since) <= options_.max_blind_time;
}

double OnlineController::LegStartTime() const {
  const std::vector<planner::MissionLeg>& legs = to_.plan->mission_legs;
  return next_junction_ > 0 && next_junction_ <= legs.size() ? legs[next_junction_ - 1].end_s : 0.0;
}

double OnlineController::NextJunctionTime() const {
  const double end = to_.plan->trajectory->duration();
  const std::vector<planner::MissionLeg>& legs = to_.plan->mission_legs;
  if (next_junction_ + 1 < legs.size()) return std::min(end, legs[next_junction_].end_s);
  return end;
}

void OnlineController::StartMissionHold(double t) {
  // The brake stops at or before the next junction: the legs meet at rest
  // there, and the junction's wait and the gripper need the plan's clock
  // to reach it as flown, not braked through.
  const double now = t - to_.start;
  const double stop_by = std::max(now, NextJunctionTime());
  link_brake_duration_ = std::max(1e-3, std::min(link_brake_duration_, 2.0 * (stop_by - now)));
  mission_hold_ = true;
  mission_brake_from_ = now;
  mission_stop_time_ = std::min(stop_by, now + 0.5 * link_brake_duration_);
  mission_resume_start_ = -1.0;
  mission_slow_link_noted_ = false;
  rejoin_checked_ = false;
  // The plan clock stands still (for the verdict) from the brake's start:
  // one pause there, grown each tick by what the warped clock lags.
  plan_clock_.PauseAt(now);
  // The plan is flown again at its own speed: the link must allow it.
  const planner::WholeBodyTrajectory& trajectory = *to_.plan->trajectory;
  mission_hold_speed_ = 0.0;
  for (double tau = mission_stop_time_; tau <= trajectory.duration(); tau += 0.02) {
    mission_hold_speed_ = std::max(mission_hold_speed_, trajectory.Sample(tau).velocity.norm());
  }
}

void OnlineController::MissionHoldClock(double t, double* plan_time, double* rate, double* rate_change) const {
  // The brake: the clock's rate falls on a smoothstep from 1 to 0, so that
  // the acceleration streamed has no step at either end.
  if (mission_resume_start_ < 0.0) {
    const double d = link_brake_duration_;
    const double u = std::clamp((t - link_hold_start_) / d, 0.0, 1.0);
    *plan_time = std::min(mission_stop_time_, mission_brake_from_ + d * (u - u * u * u + 0.5 * u * u * u * u));
    *rate = 1.0 - (3.0 * u * u - 2.0 * u * u * u);
    *rate_change = -(6.0 * u - 6.0 * u * u) / d;
    return;
  }
  // Back along the plan to the leg's start, on a smoothstep clock: at
  // rest at both ends.
  const double d = mission_ramp_duration_;
  const double span = mission_stop_time_ - mission_leg_start_;
  const double u = std::clamp((t - mission_resume_start_) / d, 0.0, 1.0);
  *plan_time = mission_stop_time_ - span * (3.0 * u * u - 2.0 * u * u * u);
  *rate = -span * (6.0 * u - 6.0 * u * u) / d;
  *rate_change = -span * (6.0 - 12.0 * u) / (d * d);
}

std::optional<Setpoint> OnlineController::MissionHoldReference(double t) const {
  double plan_time = 0.0, rate = 0.0, rate_change = 0.0;
  MissionHoldClock(t, &plan_time, &rate, &rate_change);
  const planner::WholeBodySample s = to_.plan->trajectory->Sample(plan_time);
  Setpoint sp = FromSample(s);
  if (rate <= 0.0) return HoldAt(sp);
  sp.velocity = rate * s.velocity;
  sp.acceleration = rate * rate * s.acceleration + rate_change * s.velocity;
  sp.yaw_rate *= rate;
  sp.joint_rates *= rate;
  return sp;
}

void OnlineController::HoldMission(double t, ControllerOutput* out) {
  // Keep t - to_.start the warped plan time, so that everything reading the
  // plan's clock (the gripper, the junctions, the end) reads it right; the
  // plan clock's last pause takes the lag.
  double plan_time = 0.0, rate = 0.0, rate_change = 0.0;
  MissionHoldClock(t, &plan_time, &rate, &rate_change);
  SetPlanTime(t, plan_time);
  if (mission_resume_start_ >= 0.0) {
    if (t - mission_resume_start_ < mission_ramp_duration_) return;
    // At the leg's start, at rest: the plan's own clock flies the leg again.
    link_hold_ = false;
    mission_hold_ = false;
    mission_resume_start_ = -1.0;
    return;
  }
  const double stopped_at = link_hold_start_ + link_brake_duration_;
  if (t < stopped_at) return;
  if (t - stopped_at > options_.outage_timeout) {
    Fail(Phase::kHoldingAfterFailure,
         Format("the mission could not go on within %.1f s of its stop (", options_.outage_timeout) +
             Format("base %.3f m and ", (position_ - to_.plan->trajectory->Sample(mission_stop_time_).position).norm()) +
             Format("tool %.3f m from the plan there, ", ToolOffPlanAtRest(mission_stop_time_)) +
             Format("moving at %.3f m/s; ", velocity_.norm()) +
             Format("resumed at rest within %.3f m, with the link good for the plan's speed)",
                    options_.resume_tolerance),
         HoldCause::kLinkFailed);
    return;
  }
  if (pending_resume_ || t - link_hold_start_ < link_brake_duration_ + options_.clock_sync.window) return;
  if (!LinkGoodOverWindow(t)) return;
  // The plan was made for a share of what the link allowed then; flown
  // again as it is, it needs the link's whole allowance to cover its speed
  // (still under the speed that brakes it, kLinkHoldSlack times that).
  const double limit = PlanningSpeedLimit() / kLinkPlanningShare;
  if (limit < mission_hold_speed_) {
    if (!mission_slow_link_noted_) {
      Event(Format("the link allows %.2f m/s, and the rest of the mission is planned at up to ", limit) +
            Format("%.2f m/s: holding until it allows that", mission_hold_speed_));
    }
    mission_slow_link_noted_ = true;
    return;
  }
  const planner::WholeBodySample stop = to_.plan->trajectory->Sample(mission_stop_time_);
  const double base_off = (position_ - stop.position).norm();
  const double tool_off = ToolOffPlanAtRest(mission_stop_time_);
  if (left_offboard_in_outage_) {
    // The autopilot's failsafe holds the vehicle where it caught it, which
    // is short of the plan's stop when the brake did not reach it (an
    // outage), with the arm where its last setpoint put it. The mission is
    // rejoined at the point of its plan in the current leg (never across a
    // junction) nearest in base and tool: the stream moves there at once
    // (the autopilot, out of OFFBOARD, ignores it), and OFFBOARD again
    // moves the base and the arm there, each at its own pace - so only if
    // every mix of the two moves keeps the clearance (RejoinMargin).
    if (!reengaging_ && !rejoin_checked_) {
      rejoin_checked_ = true;
      const double leg_start = LegStartTime();
      double nearest = mission_stop_time_, least = std::max(base_off, tool_off);
      for (double tau = leg_start; tau < mission_stop_time_; tau += 0.01) {
        const double base = (position_ - to_.plan->trajectory->Sample(tau).position).norm();
        if (base >= least) continue;
        const double off = std::max(base, ToolOffPlanAtRest(tau));
        if (off < least) least = off, nearest = tau;
      }
      const double margin = RejoinMargin(nearest);
      // Between the grid's mixes no body point moves more than the move's
      // largest displacement (base or tool) over the grid's spacing.
      const double spacing = least / (kRejoinGrid - 1);
      if (least > kMissionRejoinDistance || margin < spacing) {
        Fail(Phase::kHoldingAfterFailure,
             Format("the autopilot's failsafe held the vehicle %.3f m (base or tool) from the nearest point of ", least) +
                 Format("the mission's plan; moving back there could come %.4f m under the safety distance ", -margin) +
                 Format("less the tolerance (allowed: %.3f m away with a margin of the move's ", kMissionRejoinDistance) +
                 "largest step): the mission is not rejoined",
             HoldCause::kLinkFailed);
        return;
      }
      if (nearest < mission_stop_time_) {
        mission_stop_time_ = nearest;
        plan_clock_.pauses.back().first = std::min(plan_clock_.pauses.back().first, nearest);
      }
      Event(Format("rejoining the mission's plan at t = %.2f s of it, %.3f m away ", nearest, least) +
            Format("(the move keeps %.4f m over the safety distance less the tolerance)", margin));
      return;  // the next tick puts the clock and the stream there
    }
    if (!reengaging_) {
      StartReengagement(t);
      Event(Format("link good again (%.2f m/s allowed): requesting OFFBOARD again, streaming the plan's stop ", limit) +
            Format("(the vehicle is %.3f m from it)", base_off));
    }
    ReengageOffboard(t, out);
    return;
  }
  if (velocity_.norm() > kRestSpeed || std::max(base_off, tool_off) > options_.resume_tolerance) return;
  // The leg is flown again from its start, where the plan is at rest: back
  // along the plan (the same certified path) at no more than 3/4 of its
  // speed, then the leg as planned. Speeding up from rest in the middle of
  // a leg, into the plan's own acceleration, set the vehicle swinging 5 cm
  // about the plan through the gap in the campaign; from the leg's start
  // it meets the plan as it was made and checked.
  mission_leg_start_ = std::min(LegStartTime(), mission_stop_time_);
  mission_resume_start_ = t;
  mission_ramp_duration_ = std::max(1e-3, 2.0 * (mission_stop_time_ - mission_leg_start_));
  plan_clock_.pauses.back().first = std::min(plan_clock_.pauses.back().first, mission_leg_start_);
  ++stats_.link_resumes;
  outage_noted_ = false;
  junction_wait_start_ = -1.0;  // a wait at a junction the hold began in starts again
  Event(Format("link good again (%.2f m/s allowed): resuming the mission: back along its plan from ", limit) +
        Format("t = %.2f s of it (base %.3f m, ", mission_stop_time_, base_off) +
        Format("tool %.3f m off it) to its leg's start at t = %.2f s", tool_off, mission_leg_start_) +
        Format(" over %.2f s, then the leg again", mission_ramp_duration_));
}

std::optional<Setpoint> OnlineController::LinkHoldReference(double t) const {
  // Warped time: the plan's clock rate falls linearly from 1 to 0 over the
  // brake duration D, so the setpoint follows the same path and stops.
  const double elapsed = std::min(t - link_hold_start_, link_brake_duration_);
  const double rate = 1.0 - elapsed / link_brake_duration_;
  const double warped = link_hold_start_ + elapsed - elapsed * elapsed / (2.0 * link_brake_duration_);
  std::optional<Setpoint> s = Reference(warped);
  if (!s) return s;
  if (rate <= 0.0) return HoldAt(*s);
  const Vec3 path_velocity = s->velocity;
  s->velocity = rate * path_velocity;
  s->acceleration = rate * rate * s->acceleration - path_velocity / link_brake_duration_;
  s->yaw_rate *= rate;
  s->joint_rates *= rate;
  return s;
}

void OnlineController::CheckTracking(double t) {
  if (position_checked_ || phase_ != Phase::kFlying || link_hold_) return;
  position_checked_ = true;
  if (last_error_ > options_.replan_threshold) {
    MaybeReplan(t, false, last_error_);
  } else if (perceiving() ? t - std::max(last_trigger_, to_.start) >= PerceptionReplanPeriod()
                          : options_.replan_period > 0.0 && tracker_ == nullptr &&
                                t - std::max(last_trigger_, to_.start) >= options_.replan_period &&
                                last_velocity_error_ <= options_.periodic_max_velocity_error) {
    MaybeReplan(t, true, last_error_);
  }
}

void OnlineController::RequestFirstPlan(double t) {
  if (options_.require_clock_sync && !clock_.synced()) return;
  // The link's speed limit is taken over a second of its blind times, not
  // from the first exchange.
  if (clock_.synced() && (blind_history_.empty() || t - blind_history_.front().first < kLinkSettleTime)) return;
  const double limit = PlanningSpeedLimit();
  if (limit < options_.min_link_speed) {
    if (!waiting_for_link_noted_) {
      Event(Format("the link allows only %.3f m/s: waiting for it before planning", limit));
      waiting_for_link_noted_ = true;
    }
    return;
  }
  Worker::Job job;
  if (tracker_ != nullptr) {
    // Planned once the vehicle is offboard and armed, against the
    // prediction from a t = 0 fixed now (target_plan_lead).
    if (phase_ != Phase::kWaitingForPlan) return;
    prediction_zero_ = t + options_.target_plan_lead;
    if (!PredictTarget(prediction_zero_, &job.target_motion, &job.target_placement)) {
      if (!target_wait_noted_) Event("waiting for the target's measurements before planning");
      target_wait_noted_ = true;
      return;
    }
  }
  if (perceiving()) {
    if (gate_->counts().taken < setup_.perception.min_frames || SensorSilent(t) ||
        t - last_local_request_ < PerceptionReplanPeriod() || worker_->busy()) {
      return;
    }
    job.map = map_;
    last_local_request_ = t;
    blocked_since_asked_.clear();
  }
  job.start.position = hold_.position;
  job.start.yaw = hold_.yaw;
  job.start.joints = hold_.joints;
  job.start.joint_rates = hold_.joint_rates;
  job.requested_at = t;
  job.v_max = limit;
  job.from_rest = true;
  job.pre_grasp = PlansToPreGrasp();
  worker_->Submit(std::move(job));
  first_plan_requested_ = true;
  Event(Format("planning from the hold") +
        (limit < setup_.task->limits.v_max ? Format(" (speed limit %.2f m/s for the link)", limit) : std::string()));
}

bool OnlineController::CommandUntilConfirmed(double t, Command command, bool confirmed, const std::string& name,
                                             ControllerOutput* out) {
  if (confirmed) return true;
  if (attempts_ > 0 && t - last_command_time_ < options_.ack_timeout) return false;
  if (attempts_ >= options_.max_command_attempts) {
    Fail(Phase::kHandshakeFailed, "no " + name + " acknowledgement after " + std::to_string(attempts_) + " attempts");
    return false;
  }
  out->commands.push_back({command, attempts_});
  if (attempts_ == 0) Event("requesting " + name);
  ++attempts_;
  last_command_time_ = t;
  return false;
}

void OnlineController::RunHandshake(double t, ControllerOutput* out) {
  if (phase_ == Phase::kRequestingOffboard) {
    if (vehicle_offboard_ && seen_heartbeat_) offboard_confirmed_ = true;
    if (!CommandUntilConfirmed(t, Command::kSetOffboardMode, offboard_confirmed_, "OFFBOARD", out)) return;
    phase_ = Phase::kArming;
    attempts_ = 0;
  }
  if (phase_ == Phase::kArming) {
    if (vehicle_armed_ && seen_heartbeat_) armed_confirmed_ = true;
    if (!CommandUntilConfirmed(t, Command::kArm, armed_confirmed_, "arming", out)) return;
    confirmed_time_ = t;
    phase_ = Phase::kWaitingForPlan;
    Event(first_plan_ ? "offboard and armed" : "offboard and armed: waiting for the plan");
  }
}

double MeasuredClearance(const robot::RobotModel& robot, const env::ExactMeshModel& exact, const MeasuredState& state,
                         double reach, robot::KinematicsState* kinematics, int* link) {
  robot::ComputeKinematics(robot, MakePose(state.position, state.attitude.toRotationMatrix()), state.joints,
                           kinematics);
  return env::WholeBodyClearance(*kinematics, exact, reach, {}, link);
}

double MeasuredClearance(const robot::RobotModel& robot, const env::ExactMeshModel& exact,
                         const env::ExactMeshModel* moving, const Pose& task_target, const std::optional<Pose>& target,
                         const MeasuredState& state, double reach, int* link) {
  robot::KinematicsState kinematics;
  robot::ComputeKinematics(robot, MakePose(state.position, state.attitude.toRotationMatrix()), state.joints,
                           &kinematics);
  const Pose displacement = target ? Pose(*target * task_target.inverse()) : Pose::Identity();
  return planner::StillAndMovingClearance(kinematics, exact, moving, displacement, reach, link);
}

std::optional<double> ToolGoalError(const robot::RobotModel& robot, const planner::Task& task,
                                    const MeasuredState& state) {
  const int tool = robot.LinkIndex(task.tool_link);
  if (!task.tool || tool < 0 || state.joints.size() != robot.num_actuated()) return std::nullopt;
  robot::KinematicsState kinematics;
  robot::ComputeKinematics(robot, MakePose(state.position, state.attitude.toRotationMatrix()), state.joints,
                           &kinematics);
  return (kinematics.link_poses[tool].translation() - task.tool->position).norm();
}

double OnlineController::ArrivalOffset() const {
  if (const auto tool_error = ToolGoalError(setup_.scene.robot, *setup_.task, measured())) return *tool_error;
  const planner::WholeBodyTrajectory& plan = *to_.plan->trajectory;
  // A mission ends where its last step leaves the tool; the base may stand
  // off its plan by TrimTool's shift.
  if (IsMission() && tool_link_ >= 0) return ToolOffPlan(plan.duration());
  return (position_ - plan.Sample(plan.duration()).position).norm();
}

double PlanClock::PlanTime(double t) const {
  double plan_time = t - start;
  for (const auto& [at, seconds] : pauses) {
    if (plan_time <= at) break;
    plan_time = std::max(at, plan_time - seconds);
  }
  return plan_time;
}

void PlanClock::PauseAt(double plan_time) {
  // A wait again where one ended (a junction's after a link hold there)
  // adds to it.
  if (pauses.empty() || std::abs(pauses.back().first - plan_time) > 1e-9) pauses.emplace_back(plan_time, 0.0);
}

double PlanClock::TimeLeaving(double plan_time) const {
  double t = start + plan_time;
  for (const auto& [at, seconds] : pauses) {
    if (at > plan_time) break;
    t += seconds;
  }
  return t;
}

Vec3 OnlineController::ToolOffsetFromPlan(double plan_time) const {
  if (tool_link_ < 0 || !HaveState() || !to_.plan) return Vec3::Zero();
  const robot::RobotModel& robot = setup_.scene.robot;
  const planner::WholeBodySample at = to_.plan->trajectory->Sample(plan_time);
  const Vec3 planned = robot::LinkPose(robot, at.BasePose(), at.joints, tool_link_).translation();
  return MeasuredTool() - planned;
}

// TrimTool: how often the shift is updated, and the share of the tool's
// offset each update takes (about a second to converge, slower than the
// autopilot's position loop, so the vehicle follows each step).
constexpr double kTrimPeriod = 0.2;
constexpr double kTrimGain = 0.3;

void OnlineController::TrimTool(double t, double junction) {
  if (options_.tool_trim <= 0.0 || tool_link_ < 0 || velocity_.norm() > options_.arrival_settle_speed ||
      (trim_updated_ >= 0.0 && t - trim_updated_ < kTrimPeriod)) {
    return;
  }
  trim_updated_ = t;
  // The tool's offset less the base's own from its setpoint: what the tilt
  // and the arm put there. The autopilot removes the base's part itself
  // (an overshoot at arrival, at rest for a moment at its turn, must not
  // wind the shift up).
  const Vec3 base_offset = position_ - (to_.plan->trajectory->Sample(junction).position + tool_trim_);
  Vec3 trim = tool_trim_ - kTrimGain * (ToolOffsetFromPlan(junction) - base_offset);
  if (trim.norm() > options_.tool_trim) trim *= options_.tool_trim / trim.norm();
  // The step from the old shift to the new one is short (a fraction of a
  // centimetre): the new shift's configurations stand for it.
  if (TrimmedMargin(trim, junction) >= 0.0) tool_trim_ = trim;
}

std::string OnlineController::TrimWords() const {
  return Format("the base's setpoints shifted by %.4f m to bring the tool there", tool_trim_.norm());
}

double OnlineController::TrimmedMargin(const Vec3& trim, double junction) const {
  // The junction with the leg that ends there, and the next leg with its own
  // robot from its start (the time alone would name the leg before it).
  const std::vector<planner::MissionLeg>& legs = to_.plan->mission_legs;
  const planner::MissionLeg* ending = next_junction_ < legs.size() ? &legs[next_junction_] : nullptr;
  double margin = PathMargin(junction, junction, trim, {}, ending, nullptr, nullptr);
  if (margin < 0.0 || next_junction_ + 1 >= legs.size()) return margin;
  const planner::MissionLeg& next = legs[next_junction_ + 1];
  return std::min(margin, PathMargin(next.start_s, next.end_s, trim, {}, &next, nullptr, nullptr));
}

double OnlineController::ToolOffPlanAtRest(double plan_time) const {
  if (tool_link_ < 0 || !HaveState() || !to_.plan) return 0.0;
  const robot::RobotModel& robot = setup_.scene.robot;
  const planner::WholeBodySample at = to_.plan->trajectory->Sample(plan_time);
  const Mat3 attitude = attitude_.toRotationMatrix();
  const Vec3 planned = robot::LinkPose(robot, MakePose(at.position, attitude), at.joints, tool_link_).translation();
  const Vec3 measured = robot::LinkPose(robot, MakePose(position_, attitude), joints_, tool_link_).translation();
  return (measured - planned).norm();
}

void OnlineController::SetPlanTime(double t, double plan_time) {
  const double stood = (t - to_.start) - plan_time;
  to_.start += stood;
  plan_clock_.pauses.back().second += stood;
}

void OnlineController::WaitAtJunction(double t) {
  const std::vector<planner::MissionLeg>& legs = to_.plan->mission_legs;
  if (legs.empty() || next_junction_ + 1 >= legs.size()) return;
  const double junction = legs[next_junction_].end_s;
  if (t - to_.start < junction) return;
  // The plan is at rest here: standing its clock still streams the same
  // setpoint and changes nothing it was checked with.
  const double error = ToolOffPlan(junction);
  const double speed = velocity_.norm();
  const std::string where = "the end of leg " + std::to_string(next_junction_) + " (" +
                            planner::StepName(setup_.task->mission, legs[next_junction_].step) + ")";
  if (error <= options_.junction_tolerance && speed <= options_.arrival_settle_speed) {
    if (junction_wait_start_ >= 0.0) {
      Event("settled at " + where +
            Format(" after waiting %.2f s", t - junction_wait_start_) + Format(" (tool %.4f m off)", error) +
            (tool_trim_.norm() > 0.0 ? "; " + TrimWords() : std::string()));
    }
    junction_wait_start_ = -1.0;
    ++next_junction_;
    return;
  }
  if (junction_wait_start_ < 0.0) {
    junction_wait_start_ = t;
    plan_clock_.PauseAt(junction);
    Event("waiting at " + where + Format(" for the vehicle to settle (tool %.4f m off, ", error) +
          Format("base %.3f m/s)", speed));
  }
  if (t - junction_wait_start_ > options_.junction_timeout) {
    Fail(Phase::kHoldingAfterFailure,
         Format("the tool did not settle within %.4f m of its planned pose at ", options_.junction_tolerance) + where +
             Format(" in %.1f s", options_.junction_timeout) + Format(" (%.4f m off, ", error) +
             Format("base %.3f m/s)", speed),
         HoldCause::kToolNotSettled);
    return;
  }
  TrimTool(t, junction);
  // Hold the clock at the junction: the time since the plan reached it
  // (first tick) or since the last tick is the pause's.
  SetPlanTime(t, junction);
}

void OnlineController::CommandGripper(double t, ControllerOutput* out) {
  // Not during a link hold: the command and its acknowledgement need the
  // link, and the plan's clock stops short of the gripper's step.
  if (!IsMission() || !to_.plan || (phase_ != Phase::kFlying && phase_ != Phase::kArrived) || link_hold_) return;
  const std::vector<planner::MissionStep>& mission = setup_.task->mission;
  if (gripper_pending_ >= 0) {
    // Not acknowledged: resend after the acknowledgement timeout, a few times.
    if (t - gripper_sent_at_ < options_.ack_timeout) return;
    if (gripper_attempts_ >= options_.max_command_attempts) {
      const std::string step = planner::StepName(mission, static_cast<size_t>(gripper_pending_));
      gripper_pending_ = -1;
      Fail(Phase::kHoldingAfterFailure, "no acknowledgement of the gripper command of " + step,
           HoldCause::kGripperFailed);
      return;
    }
    out->commands.push_back({Command::kGripper, gripper_attempts_++,
                             mission[gripper_pending_].kind == planner::StepKind::kGrasp});
    gripper_sent_at_ = t;
    return;
  }
  const std::vector<planner::StepResult>& steps = to_.plan->steps;
  while (next_gripper_step_ < mission.size() && next_gripper_step_ < steps.size()) {
    const planner::MissionStep& step = mission[next_gripper_step_];
    if (!planner::GripperActsAt(step)) {
      ++next_gripper_step_;
      continue;
    }
    // The gripper acts when its step has begun (the plan is at rest there)
    // and the measured tool is where the plan put it.
    const planner::StepResult& planned = steps[next_gripper_step_];
    if (t - to_.start < planned.start_s || junction_wait_start_ >= 0.0) return;
    const double error = ToolOffPlan(planned.start_s);
    if (error > options_.gripper_tolerance) {
      if (t - to_.start > 0.5 * (planned.start_s + planned.end_s)) {
        Fail(Phase::kHoldingAfterFailure,
             Format("the tool did not settle within %.4f m of its pose for ", options_.gripper_tolerance) +
                 planner::StepName(mission, next_gripper_step_) + Format(" (%.4f m off)", error),
             HoldCause::kToolNotSettled);
      }
      return;
    }
    const bool grab = step.kind == planner::StepKind::kGrasp;
    out->commands.push_back({Command::kGripper, 0, grab});
    gripper_pending_ = static_cast<long>(next_gripper_step_);
    gripper_sent_at_ = t;
    gripper_attempts_ = 1;
    Event(std::string(grab ? "closing" : "opening") + " the gripper (" + planner::StepName(mission, next_gripper_step_) +
          ")");
    ++next_gripper_step_;
    return;
  }
}

ControllerOutput OnlineController::Tick(double t) {
  ControllerOutput out;
  if (!ticked_) {
    ticked_ = true;
    first_tick_ = t;
    next_heartbeat_ = t;
  }
  if (previous_tick_ >= 0.0 && t > previous_tick_) {
    constexpr double kPeriodSmoothing = 0.05;  // about the last 20 periods
    const double period = t - previous_tick_;
    streaming_period_ =
        streaming_period_ > 0.0 ? streaming_period_ + kPeriodSmoothing * (period - streaming_period_) : period;
  }
  previous_tick_ = t;
  CollectPlan(t);
  if (have_position_ && !age_noted_) {
    // Its age when it was first looked at (it arrived within the last tick).
    const double age = std::max(0.0, t - position_time_);
    stats_.max_state_age = std::max(stats_.max_state_age, age);
    stats_.sum_state_age += age;
    age_noted_ = true;
  }

  // The vehicle's silence ends everything.
  if (phase_ != Phase::kVehicleLost && phase_ != Phase::kHandshakeFailed && !arrival_done_) {
    // A mission is not resumed after an outage, but its brake is waited for.
    const bool outage = phase_ == Phase::kFlying && (!IsMission() || link_hold_);
    const double silence = t - position_time_;
    if (have_position_ && silence > options_.vehicle_timeout && outage && silence <= options_.outage_timeout) {
      if (!outage_noted_) {
        Event(Format("no position from the vehicle for %.2f s: an outage; holding and waiting ", silence) +
              Format("up to %.1f s for the link (the hold is streamed; if it does not reach the vehicle, the ",
                     options_.outage_timeout) +
              "autopilot's offboard-loss failsafe holds it)");
      }
      outage_noted_ = true;
    } else if (have_position_ && silence > options_.vehicle_timeout) {
      Fail(Phase::kVehicleLost, Format("no position from the vehicle for %.2f s", silence));
    } else if (!HaveState() && t - first_tick_ > options_.connect_timeout) {
      Fail(Phase::kVehicleLost, Format("no complete vehicle state within %.1f s", options_.connect_timeout));
    } else if (options_.require_clock_sync && !clock_.synced() && t - first_tick_ > options_.connect_timeout) {
      Fail(Phase::kHandshakeFailed,
           Format("the vehicle did not answer TIMESYNC within %.1f s: the age of its states cannot be known "
                  "(flying on arrival times needs require_clock_sync off)",
                  options_.connect_timeout));
    }
  }

  switch (phase_) {
    case Phase::kWaitingForVehicle:
      if (HaveState()) {
        hold_ = HoldAtMeasuredPose();
        hold_start_ = t;
        phase_ = Phase::kStreamingHold;
        if (perceiving()) {
          // No sensor sees the vehicle's own space.
          map_->Start(position_, setup_.perception.start_free_radius);
          last_progress_ = t;
        }
        Event(Format("vehicle state received: holding at (%.3f, ", position_.x()) +
              Format("%.3f, %.3f)", position_.y(), position_.z()));
      }
      break;
    case Phase::kStreamingHold:
      if (t - hold_start_ >= options_.hold_time) {
        phase_ = Phase::kRequestingOffboard;
        attempts_ = 0;
      }
      break;
    default:
      break;
  }
  if (phase_ == Phase::kRequestingOffboard || phase_ == Phase::kArming) RunHandshake(t, &out);
  if (!first_plan_requested_ && phase_ != Phase::kWaitingForVehicle && !finished() &&
      phase_ != Phase::kHoldingAfterFailure) {
    RequestFirstPlan(t);
  }

  if (perceiving()) CheckSensor(t);
  if (phase_ == Phase::kWaitingForPlan && first_plan_ && (tracker_ == nullptr || t >= prediction_zero_) &&
      !(perceiving() && SensorSilent(t))) {
    const double offset = (position_ - hold_.position).norm();
    const bool settled = offset <= options_.start_tolerance;
    const bool may_start = settled || t - confirmed_time_ >= options_.settle_timeout;
    if (tracker_ != nullptr && (!may_start || t > prediction_zero_ + kLatestTargetStart)) {
      // A moving target's plan starts at its t = 0 or not at all: later, the
      // target is no longer where it was planned to meet it.
      first_plan_.reset();
      first_target_.reset();
      first_plan_requested_ = false;
      Event(may_start ? "the plan came too late for the target: planning again"
                      : "the vehicle has not settled at the hold by the plan's start: planning again");
    } else if (may_start) {
      const double start = tracker_ != nullptr ? prediction_zero_ : t;
      to_ = {first_plan_, start, first_target_, first_local_};
      plan_clock_ = PlanClock{start, {}};
      last_progress_ = t;
      phase_ = Phase::kFlying;
      Event(settled ? Format("flying the plan (%.3f m from the start)", offset)
                    : Format("flying the plan although the vehicle is still %.3f m from the start", offset));
    }
  }
  CheckLink(t, &out);
  if (phase_ == Phase::kFlying) CheckTracking(t);
  if (phase_ == Phase::kFlying && !link_hold_) {
    if (blending_ && t >= blend_start_ + splice_window_) {
      blending_ = false;
      from_ = ActivePlan{};
    }
    if (IsMission()) WaitAtJunction(t);
    if (phase_ == Phase::kFlying && !blending_ && !retreating_ && SettlesFirst() &&
        target_stage_ == TargetStage::kApproach && t - to_.start >= to_.plan->trajectory->duration()) {
      target_stage_ = TargetStage::kSettling;
      settle_start_ = t;
      // The follow must keep its clearance until the insertion's plan takes
      // over (target_plan_lead after the request), against the still scene.
      const double clear = ClearFollowDuration(options_.target_settle_timeout + options_.target_plan_lead);
      settle_limit_ = std::max(0.0, clear - options_.target_plan_lead);
      Event("at the insertion's start: following the target until the tool has settled there" +
            (settle_limit_ < options_.target_settle_timeout
                 ? Format(" (at most %.2f s: farther the follow would come under the safety distance less the "
                          "tolerance)",
                          settle_limit_)
                 : std::string()));
    }
    if (phase_ == Phase::kFlying && target_stage_ == TargetStage::kSettling) Settle(t);
    if (phase_ == Phase::kFlying && !blending_ && !retreating_ && target_stage_ != TargetStage::kSettling &&
        !to_.to_local_target && t - to_.start >= to_.plan->trajectory->duration()) {
      phase_ = Phase::kArrived;
      arrival_time_ = t;
      if (tracker_ != nullptr) {
        follow_duration_ = ClearFollowDuration(options_.arrival_hold);
        Event(Format("the plan has ended: following the target for %.2f s", follow_duration_) +
              (follow_duration_ < options_.arrival_hold
                   ? Format(" (farther would come under the safety distance less the tolerance)")
                   : std::string()));
      } else {
        Event("the plan has ended: holding at the goal");
      }
    }
  }
  if (tracker_ != nullptr) CheckTarget(t);
  CheckAbort(t);
  CheckJointStall(t);
  if (phase_ == Phase::kArrived && !arrival_done_ && !aborted_ && tracker_ == nullptr) {
    TrimTool(t, to_.plan->trajectory->duration());
  }
  if (phase_ == Phase::kArrived && !arrival_done_ && !aborted_ && tracker_ != nullptr &&
      t - arrival_time_ >= follow_duration_) {
    arrival_done_ = true;
    arrival_settled_ = stats_.arrival_target_error <= options_.target_arrival_tolerance;
    Event(Format("followed the target for %.2f s: the tool was %.4f m from it at the arrival, ", t - arrival_time_,
                 stats_.arrival_target_error) +
          Format("at most %.4f m while following: done", stats_.max_follow_target_error));
  }
  if (phase_ == Phase::kArrived && !arrival_done_ && !aborted_ && gripper_pending_ < 0 && tracker_ == nullptr &&
      t - arrival_time_ >= options_.arrival_hold) {
    const double offset = ArrivalOffset();
    const double speed = velocity_.norm();
    arrival_settled_ = offset <= options_.arrival_tolerance && speed <= options_.arrival_settle_speed;
    if (arrival_settled_ || t - arrival_time_ >= options_.arrival_timeout) {
      arrival_done_ = true;
      Event(Format(arrival_settled_ ? "settled at the goal after %.2f s of holding" : "not settled after %.2f s of holding",
                   t - arrival_time_) +
            Format(" (%.4f m off, ", offset) + Format("%.4f m/s): done", speed) +
            (tool_trim_.norm() > 0.0 ? " (" + TrimWords() + ")" : std::string()));
    }
  }

  CommandGripper(t, &out);

  std::optional<Setpoint> setpoint;
  bool in_blend = false;
  // Sampled ahead, so that the setpoint the autopilot flies until the next
  // one is on average where the plan is (OnlineOptions::setpoint_lead).
  const double at = t + SetpointLead();
  switch (phase_) {
    case Phase::kStreamingHold:
    case Phase::kRequestingOffboard:
    case Phase::kArming:
    case Phase::kWaitingForPlan:
    case Phase::kHoldingAfterFailure:
      setpoint = hold_;
      break;
    case Phase::kFlying:
      if (retreating_) {
        setpoint = RetreatReference(at);
      } else if (link_hold_ && mission_hold_) {
        setpoint = MissionHoldReference(at);
      } else if (link_hold_) {
        setpoint = hold_until_resume_ ? hold_ : LinkHoldReference(at);
      } else {
        setpoint = Reference(at);
        in_blend = blending_ && at >= blend_start_;
      }
      break;
    case Phase::kArrived:
      if (retreating_) {
        setpoint = RetreatReference(at);
      } else if (to_.target) {
        setpoint = Reference(at);  // following the target
      } else {
        setpoint = HoldAt(FromSample(to_.plan->trajectory->Sample(to_.plan->trajectory->duration())));
      }
      break;
    default:
      break;
  }
  if (arrival_done_ || abort_done_) setpoint.reset();
  if (setpoint) {
    if (last_setpoint_) {
      const double step = (setpoint->position - last_setpoint_->position).norm();
      const double speed = t > last_setpoint_time_ ? step / (t - last_setpoint_time_) : 0.0;
      stats_.max_setpoint_step = std::max(stats_.max_setpoint_step, step);
      stats_.max_setpoint_speed = std::max(stats_.max_setpoint_speed, speed);
      if (in_blend || last_setpoint_in_blend_) {
        stats_.max_splice_step = std::max(stats_.max_splice_step, step);
        stats_.max_splice_speed = std::max(stats_.max_splice_speed, speed);
      }
    }
    last_setpoint_ = setpoint;
    last_setpoint_time_ = t;
    last_setpoint_in_blend_ = in_blend;
    ++stats_.setpoints;
    // Into the frame of the vehicle's estimate, where the autopilot flies,
    // and shifted to bring the tool to its pose (TrimTool).
    Vec3 target_shift, target_rate;
    TargetCorrection(at, &target_shift, &target_rate);
    last_setpoint_shift_ = tool_trim_ + target_shift;
    setpoint->position += stats_.estimate_shift + last_setpoint_shift_;
    setpoint->velocity += target_rate;
    out.setpoint = std::move(setpoint);
  }
  const bool streaming_phase = phase_ != Phase::kVehicleLost && phase_ != Phase::kHandshakeFailed && !arrival_done_;
  if (streaming_phase) out.timesync_request = clock_.RequestDue(t);
  if (streaming_phase && t >= next_heartbeat_) {
    out.send_heartbeat = true;
    next_heartbeat_ += options_.heartbeat_period;
    if (next_heartbeat_ <= t) next_heartbeat_ = t + options_.heartbeat_period;
  }
  out.events = std::move(events_);
  events_.clear();
  out.phase = phase_;
  return out;
}

}  // namespace quadhand::online

#include "quadhand/explore/exploration_flight.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <optional>

#include "quadhand/explore/look_round.h"
#include "quadhand/robot/kinematics.h"

namespace quadhand::explore {
namespace {

bool Fail(std::string* why, const std::string& message) {
  if (why != nullptr) *why = message;
  return false;
}

sim::Setpoint SetpointOf(const planner::WholeBodySample& sample) {
  sim::Setpoint s;
  s.position = sample.position;
  s.velocity = sample.velocity;
  s.acceleration = sample.acceleration;
  s.jerk = sample.jerk;
  s.yaw = sample.yaw;
  s.yaw_rate = sample.yaw_rate;
  s.joints = sample.joints;
  s.joint_rates = sample.joint_rates.size() == sample.joints.size() ? sample.joint_rates : VecX::Zero(sample.joints.size());
  return s;
}

// A plan being flown: its trajectory from `t0` on the simulated clock. A
// brake slows the plan's own clock to a stop (rate 1 - smoothstep over
// brake_s): the vehicle passes through the plan's positions, yaws and
// joints only, more slowly, and holds at the one where the clock stops.
// Its tilt is not the plan's: the deceleration tilts it back (by at most
// atan(a / 2g), a the limit braked with), which the plan's tracking margin
// has to absorb.
struct FlownPlan {
  planner::WholeBodyTrajectory trajectory;
  double t0 = 0.0;
  bool to_goal = false;
  // A plan to the goal or nearer it (LocalPlanResult::progress): the
  // headings looked along before it are from elsewhere.
  bool progress = false;
  bool turn = false;  // a turn in place: flown to its end before the next replan
  bool braked = false;
  double brake_t = 0.0, brake_tau = 0.0, brake_s = 0.0;

  // Plan time at t, and (when asked) its rate and the rate's first two
  // derivatives.
  double PlanTime(double t, double* rate = nullptr, double* rate_dot = nullptr, double* rate_ddot = nullptr) const {
    double r = 1.0, r1 = 0.0, r2 = 0.0, tau = t - t0;
    if (braked) {
      const double u = std::clamp((t - brake_t) / brake_s, 0.0, 1.0);
      if (u >= 1.0) {
        r = 0.0;
        tau = brake_tau + 0.5 * brake_s;
      } else {
        r = 1.0 - 3.0 * u * u + 2.0 * u * u * u;
        r1 = (-6.0 * u + 6.0 * u * u) / brake_s;
        r2 = (-6.0 + 12.0 * u) / (brake_s * brake_s);
        tau = brake_tau + brake_s * (u - u * u * u + 0.5 * u * u * u * u);
      }
    }
    if (rate != nullptr) *rate = r;
    if (rate_dot != nullptr) *rate_dot = r1;
    if (rate_ddot != nullptr) *rate_ddot = r2;
    return tau;
  }
  planner::WholeBodySample At(double t) const {
    double r = 1.0, r1 = 0.0, r2 = 0.0;
    const double tau = std::min(PlanTime(t, &r, &r1, &r2), trajectory.duration());
    planner::WholeBodySample s = trajectory.Sample(tau);
    if (!braked) return s;
    // Chain rule through the slowed clock (past the plan's end it stands still).
    if (tau >= trajectory.duration()) r = r1 = r2 = 0.0;
    const Vec3 v = s.velocity, a = s.acceleration;
    s.velocity = v * r;
    s.acceleration = a * r * r + v * r1;
    s.jerk = s.jerk * r * r * r + 3.0 * a * r * r1 + v * r2;
    s.yaw_rate *= r;
    s.joint_rates *= r;
    return s;
  }
  bool Ended(double t) const { return PlanTime(t) >= trajectory.duration(); }
  // At rest for good: ended, or braked to its stop.
  bool Stopped(double t) const { return Ended(t) || (braked && t >= brake_t + brake_s); }
  // Brakes from t: over max(0.5 s, 3 v / a_max), v the plan's speed there,
  // so the clock's slowing asks at most a_max / 2 along the path.
  // Returns the speed braked from (nothing to brake: 0, when ended).
  double Brake(double t, double a_max) {
    if (braked || Ended(t)) return 0.0;
    const double tau = t - t0;
    const double speed = trajectory.Sample(tau).velocity.norm();
    braked = true;
    brake_t = t;
    brake_tau = tau;
    brake_s = std::max(0.5, 3.0 * speed / a_max);
    return speed;
  }
};

}  // namespace

bool ExplorationOptions::IsValid(std::string* why) const {
  if (std::string map_why; !map.IsValid(&map_why)) return Fail(why, "map: " + map_why);
  if (!(std::isfinite(replan_period) && replan_period >= 0.01 && replan_period <= 60.0)) {
    return Fail(why, "replan_period must be in [0.01, 60] s");
  }
  if (!(std::isfinite(plan_ahead) && plan_ahead >= 0.0 && plan_ahead < replan_period)) {
    return Fail(why, "plan_ahead must be in [0, replan_period) s");
  }
  if (!(std::isfinite(start_free_radius) && start_free_radius >= 0.0 && start_free_radius <= 10.0)) {
    return Fail(why, "start_free_radius must be in [0, 10] m");
  }
  if (miss_stride < 1 || miss_stride > 64) return Fail(why, "miss_stride must be in [1, 64]");
  if (!(std::isfinite(goal_tolerance) && goal_tolerance > 0.0 && goal_tolerance <= 10.0)) {
    return Fail(why, "goal_tolerance must be in (0, 10] m");
  }
  if (!(std::isfinite(time_limit) && time_limit >= 0.0 && time_limit <= sim::kMaxSimulatedSeconds)) {
    return Fail(why, "time_limit must be in [0, 3600] s");
  }
  if (!(std::isfinite(stuck_time) && stuck_time > 0.0)) return Fail(why, "stuck_time must be > 0 s");
  if (std::string gate_why; !frame_gate.IsValid(&gate_why)) return Fail(why, "frame gate: " + gate_why);
  if (!(std::isfinite(sensor_timeout) && sensor_timeout > 0.0 && sensor_timeout <= 60.0)) {
    return Fail(why, "sensor_timeout must be in (0, 60] s");
  }
  if (std::string faults_why; !sensor_faults.IsValid(&faults_why)) return Fail(why, faults_why);
  if (!(std::isfinite(record_period) && record_period >= 1e-3 && record_period <= 1.0)) {
    return Fail(why, "record_period must be in [0.001, 1] s");
  }
  return true;
}

const char* ExplorationOutcomeName(ExplorationOutcome outcome) {
  switch (outcome) {
    case ExplorationOutcome::kArrived: return "arrived";
    case ExplorationOutcome::kTimeLimit: return "time_limit";
    case ExplorationOutcome::kStuck: return "stuck";
    case ExplorationOutcome::kDiverged: return "diverged";
    case ExplorationOutcome::kGraspNotCertified: return "grasp_not_certified";
  }
  return "unknown";
}

sim::SensorRenderer* HiddenWorld::At(double t) const {
  sim::SensorRenderer* now = renderer;
  for (const auto& [from, changed] : changes) {
    if (t >= from) now = changed;
  }
  return now;
}

core::Result<ExplorationResult> FlyExploration(sim::Simulator* simulator, const sim::SensorConfig& sensor,
                                               const HiddenWorld& world, const LocalPlanner& planner,
                                               const planner::Task& task, const ExplorationOptions& options,
                                               const std::function<void(const ReplanRecord&)>& progress) {
  return FlyExploration(simulator, sensor, world, std::vector<const LocalPlanner*>{&planner}, task, options, progress);
}

core::Result<ExplorationResult> FlyExploration(sim::Simulator* simulator, const sim::SensorConfig& sensor,
                                               const HiddenWorld& world, const std::vector<const LocalPlanner*>& legs,
                                               const planner::Task& task, const ExplorationOptions& options,
                                               const std::function<void(const ReplanRecord&)>& progress) {
  return FlyExploration(simulator, sensor, world, legs, task, options, GraspFlight{}, progress);
}

core::Result<ExplorationResult> FlyExploration(sim::Simulator* simulator, const sim::SensorConfig& sensor,
                                               const HiddenWorld& world, const std::vector<const LocalPlanner*>& legs,
                                               const planner::Task& task, const ExplorationOptions& options,
                                               const GraspFlight& grasp,
                                               const std::function<void(const ReplanRecord&)>& progress) {
  if ((grasp.work == nullptr) != (grasp.planner == nullptr) || grasp.attempts < 1) {
    return core::Status::InvalidArgument("exploration: a grasp needs its work, its planner and at least one attempt");
  }
  if (legs.empty() || std::find(legs.begin(), legs.end(), nullptr) != legs.end()) {
    return core::Status::InvalidArgument("exploration: no local planner for a leg");
  }
  if (simulator == nullptr || world.renderer == nullptr) {
    return core::Status::InvalidArgument("exploration: no simulator or sensor");
  }
  for (const auto& change : world.changes) {
    if (change.second == nullptr || !std::isfinite(change.first)) {
      return core::Status::InvalidArgument("exploration: a change of the hidden world without a renderer or a time");
    }
  }
  if (std::string why; !options.IsValid(&why)) return core::Status::InvalidArgument("exploration: " + why);
  const sim::VehicleModel& model = simulator->model();
  const robot::RobotModel& robot = model.robot();
  const int link = robot.LinkIndex(sensor.link);
  if (link < 0) return core::Status::InvalidArgument("exploration: the robot has no link '" + sensor.link + "'");
  if (task.start.joints.size() != static_cast<long>(robot.ActuatedJointNames().size())) {
    return core::Status::InvalidArgument("exploration: the task's joints do not match the simulated robot's");
  }
  auto map = perception::RollingMap::Create(options.map);
  if (!map.ok()) return map.status();
  std::unique_ptr<GraspMap> grasp_map;
  int tool_link = -1;
  if (grasp.work != nullptr) {
    auto created = GraspMap::Create(*grasp.work, grasp.options, options.map);
    if (!created.ok()) return created.status();
    grasp_map = std::move(*created);
    tool_link = robot.LinkIndex(task.tool_link);
    if (tool_link < 0) return core::Status::InvalidArgument("exploration: the robot has no tool link '" + task.tool_link + "'");
  }
  // The grasp's phase: planning it at rest (grasping), then flying it.
  bool grasping = false, grasp_flying = false, gripper_closed = false;
  std::map<double, std::vector<Vec3>> grasp_misses;  // the grasp map's frames' misses, by the frame's time
  double next_grasp_frame = 0.0;
  double next_grasp_try = 0.0, grasp_close_t = 0.0;
  Pose object_in_tool = Pose::Identity();  // the held object, from the gripper's close

  size_t leg = 0;
  const LocalPlanner* planner = legs[0];
  double straight = 0.0;
  Vec3 from = task.start.position;
  for (const LocalPlanner* each : legs) {
    straight += (each->goal().position - from).norm();
    from = each->goal().position;
  }
  const double time_limit =
      options.time_limit > 0.0 ? options.time_limit
                               : std::min(sim::kMaxSimulatedSeconds, 3.0 * straight / task.limits.v_max + 30.0);

  sim::VehicleState initial = sim::VehicleState::AtRest(model, task.start.position, task.start.joints);
  initial.attitude = Quat(Eigen::AngleAxisd(task.start.yaw, Vec3::UnitZ()));
  simulator->Reset(initial, 0.0);
  (*map)->MoveWindow(task.start.position);
  (*map)->MarkFree(task.start.position, options.start_free_radius);
  if (options.prior != nullptr) {
    if (core::Status s = (*map)->SetPrior(*options.prior); !s.ok()) return s;
  }
  if (grasp_map != nullptr) grasp_map->MarkFree(task.start.position, options.start_free_radius);

  planner::WholeBodySample hold_sample;
  hold_sample.position = task.start.position;
  hold_sample.velocity = hold_sample.acceleration = hold_sample.jerk = Vec3::Zero();
  hold_sample.yaw = task.start.yaw;
  hold_sample.joints = task.start.joints;
  hold_sample.joint_rates = VecX::Zero(task.start.joints.size());

  ExplorationResult result;
  result.legs = static_cast<int>(legs.size());
  std::optional<FlownPlan> flying, pending;
  std::vector<Vec3> failed_at_rest;  // targets that failed from where the vehicle holds
  int stalled = 0;  // replans in a row without a certified plan that makes progress
  // The headings looked along from where the vehicle holds, and the
  // sensor's axis (its frame's) and horizontal field of view.
  const bool depth = sensor.kind == sim::SensorKind::kDepth;
  const Vec3 sensor_axis = depth ? Vec3::UnitZ() : Vec3::UnitX();
  LookRound look(depth ? sensor.depth.horizontal_fov_deg * M_PI / 180.0 : 2.0 * M_PI);
  auto sensor_pose_of = [&](const Vec3& position, const Quat& attitude, const VecX& joints) {
    return robot::LinkPose(robot, MakePose(position, attitude.toRotationMatrix()), joints, link) * sensor.Mount();
  };
  // The flown tool's pose now (the vehicle's own state).
  auto tool_pose = [&]() {
    const sim::VehicleState& now = simulator->state();
    return robot::LinkPose(robot, MakePose(now.position, now.attitude.toRotationMatrix()), now.joints, tool_link);
  };
  SensorFaults faults(options.sensor_faults, options.fault_seed);
  const double planned_distance = planner->PlannedSafetyDistance(options.map.resolution);
  perception::FrameGate gate(options.frame_gate);
  std::optional<SilenceRecord> silence;
  const double frame_period = 1.0 / sensor.rate();
  const double dt = simulator->step();
  double next_frame = 0.0, next_replan = 0.0, next_record = 0.0, last_new_plan = 0.0;
  while (true) {
    const double t = simulator->time();
    if (pending && t >= pending->t0 - 1e-9) {
      flying = std::move(pending);
      pending.reset();
      last_new_plan = t;
      if (flying->progress) look.Clear();
    }
    const sim::VehicleState& state = simulator->state();
    if (t >= next_frame - 1e-9) {
      const Pose sensor_pose = sensor_pose_of(state.position, state.attitude, state.joints);
      if (const auto heading = LookRound::HeadingOf(sensor_pose, sensor_axis)) look.Looked(*heading);
      perception::SensorFrame sent;
      sent.t = t;
      perception::SetSensorPose(sensor_pose, &sent);
      sim::SensorRenderer* renderer = world.At(t);
      sent.points = renderer->Render(sensor_pose);
      if (options.free_misses) sent.misses = renderer->LastMisses(options.miss_stride);
      // The grasp map's voxels are a few pixels' footprint wide at a few
      // metres, so it takes denser misses than the exploration map's, at its
      // own rate (GraspOptions), kept beside the frame until the frame is
      // taken or given up.
      const bool to_grasp_map = grasp_map != nullptr && t >= next_grasp_frame - 1e-9;
      if (to_grasp_map) {
        next_grasp_frame = t + 1.0 / grasp.options.frame_rate;
        grasp_misses.emplace(t, options.free_misses ? renderer->LastMisses(grasp.options.miss_stride)
                                                    : std::vector<Vec3>{});
      }
      std::vector<Vec3> new_obstacles, new_grasp_obstacles;
      for (perception::SensorFrame& frame : faults.Pass(std::move(sent), t)) {
        if (gate.Admit(frame, t) != perception::FrameDrop::kNone) continue;
        const Pose pose = perception::SensorPose(frame);
        for (Vec3& p : frame.points) p = pose * p;
        for (Vec3& p : frame.misses) p = pose * p;
        const auto update_start = std::chrono::steady_clock::now();
        (*map)->MoveWindow(pose.translation());
        if (frame.points.empty()) ++result.empty_frames;
        QUADHAND_RETURN_IF_ERROR((*map)->Insert(frame.points, pose.translation(), frame.misses));
        result.map_update_ms.push_back(
            std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - update_start).count());
        // (Sampled once a second: memory_bytes walks the kept returns.)
        if (result.frames % 30 == 0) result.peak_map_bytes = std::max(result.peak_map_bytes, (*map)->memory_bytes());
        ++result.frames;
        const std::vector<Vec3>& blocked = (*map)->NewlyBlocked();
        new_obstacles.insert(new_obstacles.end(), blocked.begin(), blocked.end());
        if (grasp_map != nullptr) {
          const auto grasp_start = std::chrono::steady_clock::now();
          // Only the frames rendered for it (grasp_misses holds them).
          if (const auto found = grasp_misses.find(frame.t); found != grasp_misses.end()) {
            std::vector<Vec3> misses = std::move(found->second);
            grasp_misses.erase(found);
            for (Vec3& p : misses) p = pose * p;
            QUADHAND_RETURN_IF_ERROR(grasp_map->Insert(frame.points, pose.translation(), misses));
            result.grasp_map_update_ms.push_back(
                std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - grasp_start).count());
            if (grasp_flying) {
              const std::optional<Pose> held =
                  gripper_closed ? std::optional<Pose>(tool_pose() * object_in_tool) : std::nullopt;
              const std::vector<Vec3> seen = grasp_map->NewObstacles(held);
              new_grasp_obstacles.insert(new_grasp_obstacles.end(), seen.begin(), seen.end());
            }
          }
        }
      }
      next_frame += frame_period;
      // A frame older than max_age on arrival is dropped as stale by the gate.
      while (!grasp_misses.empty() && grasp_misses.begin()->first < t - options.frame_gate.max_age - 1.0) {
        grasp_misses.erase(grasp_misses.begin());
      }
      // Brakes the flown plan for a conflict at plan time `conflict` (it is
      // at `tau` now), and records how far ahead it was and where it stops.
      auto brake_for = [&](double conflict, double tau, InvalidationRecord* record) {
        record->flown = true;
        record->conflict_in = conflict - tau;
        flying->Brake(t, planner->AccelerationLimit());
        record->stop_margin = conflict - flying->PlanTime(flying->brake_t + flying->brake_s);
      };
      // The plans ahead were certified against a map that saw these voxels
      // free: each is checked again against them.
      if (!new_obstacles.empty() && (flying || pending) && !grasp_flying) {
        InvalidationRecord record;
        record.t = t;
        record.new_obstacles = new_obstacles.size();
        bool invalid = false;
        if (pending && planner->FirstConflict(pending->trajectory, 0.0, new_obstacles, planned_distance)) {
          pending.reset();
          invalid = true;
        }
        if (flying && !flying->Stopped(t)) {
          const double tau = flying->PlanTime(t);
          if (const auto conflict = planner->FirstConflict(flying->trajectory, tau, new_obstacles, planned_distance)) {
            brake_for(*conflict, tau, &record);
            pending.reset();
            invalid = true;
          }
        }
        if (invalid) {
          next_replan = t;
          result.invalidations.push_back(record);
        }
      }
      // The grasp's plan was certified on the grasp map: what that map
      // finds in space it had seen free is checked against the rest of it,
      // and a conflict brakes it along its path (planned again from its
      // stop before the gripper closes; below).
      if (!new_grasp_obstacles.empty() && grasp_flying && !flying->braked && !flying->Ended(t)) {
        const double tau = flying->PlanTime(t);
        const double distance = grasp.planner->PlannedSafetyDistance(grasp.options.resolution);
        if (const auto conflict = planner->FirstConflict(flying->trajectory, tau, new_grasp_obstacles, distance)) {
          InvalidationRecord record;
          record.t = t;
          record.new_obstacles = new_grasp_obstacles.size();
          record.grasp = true;
          brake_for(*conflict, tau, &record);
          result.invalidations.push_back(record);
        }
      }
    }
    // The sensor's silence: brake, hold, and plan nothing until it speaks.
    // (Counted from take-off until the first frame is taken.)
    const bool silent = t - std::max(gate.last_taken(), 0.0) > options.sensor_timeout;
    if (silent && !silence) {
      SilenceRecord record;
      record.from = t;
      pending.reset();
      if (flying) {
        record.speed = flying->Brake(t, planner->AccelerationLimit());
        if (flying->braked) record.brake_s = flying->brake_s;
      }
      silence = record;
    } else if (!silent && silence) {
      silence->to = t;
      silence->ended = true;
      result.silences.push_back(*silence);
      silence.reset();
      next_replan = t;
      last_new_plan = t;
    }
    const bool goal_held = (flying && flying->to_goal && !flying->braked) || (pending && pending->to_goal);
    const bool turning = flying && flying->turn && !flying->Stopped(t);
    // From the staging state on, only the grasp is planned (a braked grasp
    // holds where it stopped).
    if (!grasping && !silence && !goal_held && !turning && !pending && t >= next_replan - 1e-9) {
      const double t_start = t + options.plan_ahead;
      const planner::BoundaryState start = flying ? flying->At(t_start).State() : hold_sample.State();
      if (!start.position.allFinite()) {
        return core::Status::InvalidArgument("exploration: the state to plan from is not finite");
      }
      // One snapshot of the map serves the replan and a turn after it.
      LocalMapSnapshot snapshot = planner->Snapshot(**map, start.position);
      auto planned = planner->PlanIn(snapshot, start, 0.0, failed_at_rest);
      if (!planned.ok()) return planned.status();
      snapshot.ms = 0.0;  // its time is the replan's, counted there
      result.replans.push_back(ReplanRecord{{static_cast<const LocalPlanSummary&>(*planned)}, t, static_cast<int>(leg)});
      if (progress) progress(result.replans.back());
      const bool at_rest = !flying || flying->Stopped(t_start);
      const bool certified = IsCertified(planned->status);
      bool turned = false;
      stalled = certified && planned->progress ? 0 : stalled + 1;
      // Nothing certified from rest, or only a hop along the frontier that
      // brings the goal no nearer: a heading not looked along since the
      // last progress may show a way on, so the vehicle turns to it first.
      // Not at the first such replan: a few more frames from where it is
      // (the first replan has one) often show a way on without turning.
      if (options.look_round && stalled >= 2 && ((!certified && at_rest) || (certified && !planned->progress))) {
        const Vec3 to_goal = planner->goal().position - start.position;
        const Pose now =
            sensor_pose_of(start.position, Quat(Eigen::AngleAxisd(start.yaw, Vec3::UnitZ())), start.joints);
        const auto heading = LookRound::HeadingOf(now, sensor_axis);
        const double bearing = to_goal.head<2>().norm() > 1e-6 ? std::atan2(to_goal.y(), to_goal.x()) : start.yaw;
        if (const auto next = heading ? look.Next(*heading, bearing) : std::nullopt) {
          // The body turns by what the sensor's heading must.
          auto turn = planner->PlanTurnIn(snapshot, start, start.yaw + std::remainder(*next - *heading, 2.0 * M_PI));
          if (!turn.ok()) return turn.status();
          result.replans.push_back(ReplanRecord{{static_cast<const LocalPlanSummary&>(*turn)}, t, static_cast<int>(leg)});
          if (progress) progress(result.replans.back());
          if (IsCertified(turn->status)) {
            pending = FlownPlan{std::move(*turn->plan.trajectory), t_start, false};
            pending->turn = true;
            failed_at_rest.clear();
            turned = true;
            stalled = 0;
          } else {
            look.Looked(*next);  // a heading it cannot turn to is not tried again from here
          }
        }
      }
      if (turned) {
        // The turn is flown; a hop it was offered instead is dropped.
      } else if (certified) {
        pending = FlownPlan{std::move(*planned->plan.trajectory), t_start, planned->status == LocalPlanStatus::kToGoal};
        pending->progress = planned->progress;
        failed_at_rest.clear();
      } else if (at_rest) {
        // From rest on an unchanged map the same targets fail the same
        // way: the next replans try others first, and all again once
        // nothing new is left to try.
        if (planned->tried_targets.empty()) {
          failed_at_rest.clear();
        } else {
          failed_at_rest.insert(failed_at_rest.end(), planned->tried_targets.begin(), planned->tried_targets.end());
        }
      } else {
        failed_at_rest.clear();
      }
      next_replan = t + options.replan_period;
    }

    if (grasping && !grasp_flying && !silence && t >= next_grasp_try - 1e-9) {
      // From where the ended plan holds the vehicle, on what the grasp map has seen.
      auto planned = grasp.planner->Plan(*grasp_map, flying->At(t).State());
      if (!planned.ok()) return planned.status();
      result.grasp_attempts.push_back(GraspAttempt{t, planned->certified, planned->message, planned->obstacles, planned->ms});
      if (planned->certified && planned->plan.steps.size() > 1) {
        flying = FlownPlan{std::move(*planned->plan.trajectory), t, true};
        grasp_flying = true;
        grasp_close_t = t + planned->plan.steps[1].start_s;  // the work's steps: its reach, then the grasp
      } else if (static_cast<int>(result.grasp_attempts.size()) >= grasp.attempts) {
        result.outcome = ExplorationOutcome::kGraspNotCertified;
        break;
      } else {
        next_grasp_try = t + options.replan_period;
      }
    }
    if (grasp_flying && !gripper_closed && t >= grasp_close_t - 1e-9 && !flying->braked) {
      // The gripper closes on the object where the flown tool is: the
      // simulator carries its declared mass there from now on.
      const Pose tool = tool_pose();
      result.grasp_closed_t = t;
      result.grasp_tool_error = (tool.translation() - grasp.work->tool_position).norm();
      QUADHAND_RETURN_IF_ERROR(
          simulator->SetPayload(grasp.work->object.mass, tool.inverse() * grasp.work->object.pose.translation()));
      object_in_tool = tool.inverse() * grasp.work->object.pose;
      gripper_closed = true;
    }
    if (grasp_flying && flying->braked && flying->Stopped(t)) {
      // A silence or a new obstacle braked the grasp's plan. Before the
      // gripper closed, the grasp is planned again from where it stopped, on
      // what the grasp map has seen since (within its attempts); the rest
      // of a grasp already closed is not.
      if (gripper_closed) {
        result.outcome = ExplorationOutcome::kStuck;
        break;
      }
      grasp_flying = false;
      next_grasp_try = t;
    }
    if (grasp_flying && flying->Ended(t)) {
      result.outcome = ExplorationOutcome::kArrived;
      break;
    }
    const double goal_distance = (state.position - planner->goal().position).norm();
    if (!grasping && flying && flying->to_goal && flying->Ended(t) && goal_distance <= options.goal_tolerance) {
      ++result.legs_arrived;
      if (leg + 1 == legs.size() && grasp_map != nullptr) {
        // The staging state: the grasp is planned from here.
        grasping = true;
        next_grasp_try = t;
        continue;
      }
      if (leg + 1 == legs.size()) {
        result.outcome = ExplorationOutcome::kArrived;
        break;
      }
      // The next leg plans at once from where this one came to rest (the
      // ended plan holds the vehicle there meanwhile).
      planner = legs[++leg];
      flying->to_goal = false;
      failed_at_rest.clear();
      stalled = 0;
      look.Clear();
      next_replan = t;
      last_new_plan = t;
    }
    // The limit bounds the search for a way, not a certified grasp being
    // flown: that ends by itself, and a vehicle left mid-lift holds nothing.
    if (t >= time_limit && !grasp_flying) {
      result.outcome = ExplorationOutcome::kTimeLimit;
      break;
    }
    if (!silence && t - last_new_plan > options.stuck_time && (!flying || flying->Stopped(t)) && !pending) {
      result.outcome = ExplorationOutcome::kStuck;
      break;
    }

    const planner::WholeBodySample reference = flying ? flying->At(t) : hold_sample;
    if (t >= next_record - 1e-9) {
      sim::FlownSample f = sim::RecordFlown(*simulator, reference.position, reference.yaw);
      if (grasp_map != nullptr) f.flown.gripper = gripper_closed ? 1 : 0;
      result.samples.push_back(std::move(f));
      next_record += options.record_period;
    }
    simulator->Step(SetpointOf(reference), dt);
    if (!sim::PackState(simulator->state()).allFinite()) {
      result.outcome = ExplorationOutcome::kDiverged;
      break;
    }
  }
  result.flight_s = simulator->time();
  if (silence) {
    silence->to = result.flight_s;
    result.silences.push_back(*silence);
  }
  result.peak_map_bytes = std::max(result.peak_map_bytes, (*map)->memory_bytes());
  result.frame_counts = gate.counts();
  result.dropped_points = (*map)->dropped_points();
  result.prior_points = (*map)->prior_points();
  result.injected = faults.counts();
  result.goal_distance = (simulator->state().position - planner->goal().position).norm();
  return result;
}

}  // namespace quadhand::explore

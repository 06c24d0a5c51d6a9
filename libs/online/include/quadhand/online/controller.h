// The online controller of quadhand-online, without any transport: it is given
// the vehicle's measurements and acknowledgements with their times, and asked
// what to stream at a given time. Every time comes from the caller (an
// injected clock), so tests run it deterministically against a simulator.
//
// Phases (Phase below):
//   waiting_for_vehicle  no position, attitude and joints yet; nothing streamed
//   streaming_hold       a hold at the first measured pose, >= hold_time s,
//                        while the first plan is computed from that pose
//   requesting_offboard  MAV_CMD_DO_SET_MODE (OFFBOARD) until acknowledged
//   arming               MAV_CMD_COMPONENT_ARM_DISARM (arm) until acknowledged
//   waiting_for_plan     offboard and armed, holding until the first plan is
//                        ready and the vehicle has settled at the hold (within
//                        start_tolerance, or after settle_timeout s): a vehicle
//                        that followed its own hold until now starts on the plan
//   flying               streaming the plan (replanning when off track)
//   arrived              the plan has ended: a hold at its last setpoint for
//                        at least arrival_hold s and until the vehicle has
//                        settled there (the tool within arrival_tolerance of
//                        its goal, the base slower than arrival_settle_speed)
//                        or arrival_timeout s have passed, then finished()
//   holding_after_failure a plan failed (or failed the post-check): a hold at
//                        the last setpoint streamed, until the caller stops
//   vehicle_lost         no position for vehicle_timeout s (while flying a
//                        goal: outage_timeout s, the link hold below):
//                        nothing streamed
//   handshake_failed     OFFBOARD or arming refused or never acknowledged
//                        after max_command_attempts, or the vehicle left
//                        OFFBOARD / disarmed during the flight: nothing streamed
// Commands are retried every ack_timeout s (a command is also taken as done
// when the vehicle's heartbeat already shows the mode or the armed flag).
//
// Replanning: on every position measurement while flying, the tracking error
// |p_measured - p_setpoint(t)| is compared with replan_threshold; above it (and
// at least min_replan_interval after the last trigger, with no replan or
// splice under way, and outside the plan's insertion piece) a replan is
// started in a background thread from the measured state predicted to
// t_splice = now + replan_lead (the tracking error is taken as constant over
// the lead: measured + (reference(t_splice) - reference(now)) for position,
// velocity, yaw and joints; acceleration, jerk and rates of the reference at
// t_splice). Also every replan_period s while on track (continuous
// replanning, the same way but with the tracking error below the threshold):
// such a replan corrects the drift before it grows, usually rejoining the
// current plan after replan_options.horizon (replan.h); when it fails, or
// its plan is far slower than what is left of the current one
// (PlanRecord::dropped_as_slower), the current plan (still certified) is
// kept and flown on. Periodic replans wait while the velocity is off the
// reference (periodic_max_velocity_error). The new plan's time 0 is t_splice; it is blended in over
// blend_window s from t_splice (or from its arrival, when it comes late) as
// setpoint.h describes. A replan that fails, or fails the post-check, is
// never streamed: the controller holds at the last setpoint streamed. A start
// pushed inside the safety margin (up to ReplanOptions::max_start_penetration
// into the scene) is still replanned, under the recovery rule of replan.h;
// after a failed recovery there is no cold fallback (Plan() refuses such a
// start), so the controller holds.
//
// A moving target (goal.tool.motion; OnlineOptions' target_* fields,
// docs/moving_targets.md): measured by OnTarget, every plan made against the
// tracker's prediction; the approach goes to the insertion's start, the
// vehicle settles there following the target, the insertion is planned from
// there, and after the arrival the vehicle follows the target; the plan's
// tail is replanned (from the plan itself) as the prediction moves.
//
// Threads: planning runs in one worker thread owned by the controller; every
// other method must be called from one thread.
#pragma once

#include <deque>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "quadhand/core/status.h"
#include "quadhand/core/types.h"
#include "quadhand/explore/local_planner.h"
#include "quadhand/opt/solver.h"
#include "quadhand/online/clock_sync.h"
#include "quadhand/online/setpoint.h"
#include "quadhand/online/target_tracker.h"
#include "quadhand/perception/rolling_map.h"
#include "quadhand/perception/sensor_frame.h"
#include "quadhand/planner/planner.h"
#include "quadhand/planner/mission_plan.h"
#include "quadhand/planner/planning_context.h"
#include "quadhand/planner/replan.h"

namespace quadhand::online {

struct OnlineOptions {
  // s of hold setpoints before OFFBOARD is requested: PX4 refuses OFFBOARD
  // until setpoints have streamed for a while (1 s in the simulator); the
  // margin covers the link's latency.
  double hold_time = 1.2;
  double ack_timeout = 0.5;          // s to wait for each COMMAND_ACK
  int max_command_attempts = 5;      // per command, with confirmation counting up
  double vehicle_timeout = 1.0;      // s without a position measurement -> vehicle_lost
  // While flying a goal (not a mission), a silent vehicle is an outage: the
  // controller holds (the link hold) and waits this long (s, >=
  // vehicle_timeout) before vehicle_lost. When the autopilot's own
  // offboard-loss failsafe took it out of OFFBOARD meanwhile (its heartbeat
  // says so), it is re-engaged once the link is good: hold setpoints at
  // the measured pose for hold_time, OFFBOARD requested again, then a fresh
  // plan from the measured state at rest (stats: reengagements).
  double outage_timeout = 10.0;
  double connect_timeout = 10.0;     // s from the first Tick to the first complete state -> vehicle_lost
  bool replanning = true;
  double replan_threshold = 0.10;    // m of 3-D tracking error that triggers a replan
  double min_replan_interval = 1.0;  // s between two triggers
  double replan_lead = 0.25;         // s between a trigger and the new plan's start
  // s between periodic replans while on track (0: replan only above the
  // threshold). A periodic replan that fails keeps the current plan.
  double replan_period = 1.0;
  // m/s: on track also means a velocity this close to the reference's. A
  // periodic replan waits while the vehicle is further off (a push being
  // damped): its start is predicted with the tracking error held constant
  // over replan_lead, which the vehicle's own controller is then busy
  // shrinking, so the new plan would start from a state the vehicle never
  // reaches (measured, docs/online.md: a 0.8 m/s push met by a periodic
  // replan left the vehicle 23 cm under its new reference). Normal flights
  // keep within 0.16 m/s (p95 0.10-0.12).
  double periodic_max_velocity_error = 0.3;
  double blend_window = 0.5;         // s of old -> new blending
  // When the warm-started replan fails (solver or post-check), plan again from
  // the same start with the full pipeline (front end, cold solve): slower
  // (hundreds of ms; the blend then starts when it arrives) but it escapes
  // the old plan's homotopy, e.g. after a push towards a window frame.
  bool cold_fallback = true;
  double start_tolerance = 0.02;     // m from the hold at which the flight may start
  double settle_timeout = 3.0;       // s after arming after which it starts anyway
  // Holding at the goal before finished(): at least arrival_hold s, then
  // until the tool frame (measured base pose and joints) is within
  // arrival_tolerance m of the task's tool goal (tasks without one: the base
  // within that distance of the plan's last setpoint) and the base is slower
  // than arrival_settle_speed m/s, at most arrival_timeout s after the plan's
  // end. The arm's last motion leaves the base a few cm off (the
  // autopilot does not know the arm); the position loop brings it back in
  // about a second and may overshoot with its integral term, so a fixed
  // hold would end the flight with the tool still moving.
  double arrival_hold = 1.0;
  double arrival_tolerance = 0.003;
  // A mission's gripper closes or opens (its grasp or release step has
  // begun, the plan at rest) once the measured tool is within this many
  // metres of the planned one; a tool that is not there by the middle of
  // the step ends the mission holding (the object would be held, or left,
  // off the pose it was planned with).
  double gripper_tolerance = 0.005;
  // A mission's legs meet at rest. At each junction the plan's clock stands
  // still until the measured tool is within junction_tolerance m of where
  // the plan has it there and the base is slower than arrival_settle_speed:
  // the arm's last motion of a leg can leave the base centimetres off (the
  // autopilot does not know the arm) and the next leg (an insertion, a
  // pull, the gripper) needs the tool where it was planned. A vehicle not
  // settled after junction_timeout s ends the mission holding there.
  double junction_tolerance = 0.005;
  double junction_timeout = 5.0;
  // A steady force (wind, a payload) tilts the hovering vehicle, and the
  // tilt moves the arm: the base holds its setpoint and the tool stays off
  // its planned pose. While the plan waits at a junction with the vehicle
  // settled, the base's setpoints are shifted (a slow integral of the
  // tool's offset, at most tool_trim m) to bring the tool to its pose, as
  // long as the configuration there and the whole next leg, shifted so,
  // keep the clearance; the shift is kept over that leg (the force keeps
  // acting) and updated at the next junction; the same while holding at
  // the goal, where only the goal's configuration is checked. 0: no shift.
  double tool_trim = 0.03;
  // The autopilot flies each position setpoint until the next one comes,
  // a streaming period later: a setpoint sampled at the time it is sent is
  // on average half a period old where it is flown, and the vehicle trails
  // the plan by that much times its speed (3 mm behind a target moving at
  // 0.3 m/s over loopback at 50 Hz). Setpoints are sampled this many
  // seconds ahead; negative (the default): half the measured streaming
  // period (at most 0.05 s). 0: at the time they are sent. The uplink's
  // latency is not led: a slow link is met by its speed limit and holds.
  double setpoint_lead = -1.0;
  // The planner's collision margin (PlannerOptions::collision_margin, the
  // distance above the safety distance the optimiser aims for) is raised by
  // this much for plans flown: the flown path strays from the plan by several
  // millimetres where it turns near obstacles (up to 7 mm at the default
  // task's windows over loopback), which ate the whole margin the post-check
  // leaves (docs/online.md, "The flight margin"). The flight is still judged
  // at the safety distance less clearance_tolerance.
  double flight_margin = 0.006;
  double arrival_settle_speed = 0.01;
  double arrival_timeout = 10.0;  // >= arrival_hold; equal: a fixed hold
  double heartbeat_period = 1.0;     // s between our own heartbeats

  // Time and latency (docs/online.md, "Latency"). States are judged at the
  // time the vehicle stamped them, mapped to our clock by TIMESYNC
  // (clock_sync.h). With require_clock_sync, the flight does not start
  // until the vehicle has answered TIMESYNC (a vehicle that never does ends
  // the flight after connect_timeout of trying, before anything is flown);
  // without it, a state's arrival time is taken as its time, and the
  // latency is not known.
  bool require_clock_sync = true;
  ClockSyncOptions clock_sync;
  // A replan starts from a state at most this old (s, from the vehicle's
  // stamp to now, plus the clock's uncertainty): the start is the state
  // predicted over its age and the replan lead, and a prediction over longer
  // is not trusted. Older: no replan until a fresher state arrives.
  double max_state_age = 0.25;
  // The link budget. The blind time is the age of the newest state plus
  // the uplink latency (median): how long before a correction sent now acts
  // on what the vehicle did when we last saw it. The vehicle may fly at
  // most link_budget safety distances in that time: plans from rest (the
  // first, and after a hold) are slowed down as a whole (time_scale.h,
  // certified afresh) to 0.7 times link_budget * safety_distance over the
  // largest blind time of the last clock_sync.window s, and replans keep
  // the plan's speed limit. While flying, when the reference is faster than
  // 1.5 times what the link allows now, or the blind time exceeds
  // max_blind_time (an outage), the vehicle brakes along the plan's path and
  // holds; once the link has stayed under max_blind_time for a window and
  // allows at least min_link_speed, it flies a fresh plan from rest at the
  // measured pose. Below min_link_speed the first plan is not made: it waits.
  double link_budget = 10.0;
  double max_blind_time = 0.5;    // s
  double min_link_speed = 0.05;   // m/s
  // Exit 0 needs the flown path (the vehicle's own time-stamped states,
  // checked against the exact meshes) to keep the safety distance less this
  // tolerance (m), with no gap between two states longer than
  // max_judged_gap (s): a path not seen cannot be called safe.
  double clearance_tolerance = 0.002;
  double max_judged_gap = 0.25;
  // The innovation gate on the vehicle's position estimate: a state farther
  // than innovation_gate (m) plus 0.5 innovation_acceleration dt^2 from
  // where the one before predicts it (its position moved by the mean of
  // the two velocities over the dt between their stamps) is an estimate
  // jump (a re-localisation, a glitch). A vehicle cannot move that far
  // that fast, so one side of the jump is wrong, and the autopilot, which
  // flies on its estimate, would fly the jump at once.
  // shift_setpoints_on_jump (the default): every setpoint streamed from
  // then on is shifted by the jump, so that the vehicle stays where it
  // physically was and the flight goes on in the frame it began in (as
  // PX4's position control shifts its setpoints on an EKF2 reset); the
  // states are judged in that frame, the estimate less the jumps
  // (OnlineStats::estimate_shift). Off: the setpoints are not shifted, the
  // vehicle flies the jump, and exit 0 also needs the flown clearance less
  // the jumps' sum to keep the safety distance less the tolerance.
  double innovation_gate = 0.005;
  double innovation_acceleration = 4.0;  // m/s^2
  bool shift_setpoints_on_jump = true;
  // A mission's link hold is not replanned: its plan's clock slows to a
  // stop along the path (never past the next junction) and stands; once
  // the link is good for the plan's own speed and the vehicle is at rest
  // with its base and tool within resume_tolerance (m) of the plan's stop,
  // it goes back along the plan to the start of its leg (at rest) and flies
  // the leg again. Not resumed within outage_timeout of the stop: the
  // mission ends holding (HoldCause::kLinkFailed).
  double resume_tolerance = 0.02;
  // The abort near the goal (a goal with an insertion, not a mission): on
  // the insertion, or holding at the goal, every new state's exact
  // clearance (link meshes against the scene, as the verdict measures it)
  // is checked; below the safety distance less clearance_tolerance a fault
  // (a gust, a weak motor) is pushing the gripper into what it reaches for,
  // and the flight can no longer exit 0 anyway. The vehicle then retreats
  // along the plan itself, backwards in time (its certified path, joints
  // included), from where the reference is to the insertion's start, with
  // the clock easing in and out over twice the insertion's duration (at
  // least 1 s), holds there for abort_hold s and finishes (aborted()).
  bool abort_near_goal = true;
  double abort_hold = 2.0;
  // A joint that stops while the plan moves it (a stalled or broken servo):
  // the plan's clearance assumed the arm moves with the base. When, over
  // joint_stall_time (s) of its states, a joint's measured rate stays under
  // a tenth of the plan's while the plan has moved it at joint_stall_rate
  // (rad/s) or faster, one way, for the last 0.3 s plus the uplink, or the
  // joint is farther from the plan than the plan moved it in that time
  // (plus 0.03 rad), the vehicle brakes along the plan, holds and the
  // flight ends aborted.
  // A slow servo (a lag) still moves and is not a stall, nor is a joint
  // whose servo's goal, as the vehicle reports it (OnJointGoals), has stood
  // still while the plan moves it (the setpoints stopped coming, not the
  // joint). And whatever the
  // plan's rate: a joint more than 0.01 rad from the plan that stands
  // still (under 0.01 rad/s and a fifth of the plan's rate) for
  // joint_stall_time is a stall when the plan ahead, with that joint where
  // it stands, comes closer to the scene than the safety distance less the
  // tolerance within the brake's path plus the detection's delay.
  // 0: no check.
  double joint_stall_rate = 0.3;
  double joint_stall_time = 0.1;

  // A moving target (goal.tool.motion; docs/moving_targets.md, "Online").
  // The task's motion is not used in flight: the target is what its
  // measurements (OnTarget) say, filtered by target_tracker and predicted
  // forward as a constant motion. Every plan and replan is made against
  // that prediction from its own start, with the task's moving points
  // placed where the estimate has the target then.
  // The default filter (white acceleration 1e-5 m^2/s^3: the velocity
  // wanders about 1 cm/s in 10 s) suits a belt or a turntable running at
  // its speed; TargetTrackerOptions' own default (0.01 m^2/s^3) a cup
  // pushed by hand, at the price of a noisier velocity and so a noisier
  // grasp: the tool follows the estimate's noise down the insertion.
  TargetTrackerOptions target_tracker = [] {
    TargetTrackerOptions tracker;
    tracker.acceleration_noise = 1e-5;
    tracker.yaw_acceleration_noise = 1e-5;
    return tracker;
  }();
  // A measurement older than this on arrival (s, from its stamp) is dropped.
  double max_target_age = 0.5;
  // The first plan's t = 0 is fixed before it is made (the prediction
  // starts there): target_plan_lead s after it is requested, once the
  // vehicle is offboard and armed. A plan ready later than that, or a
  // vehicle not settled by then (until settle_timeout), is planned again.
  double target_plan_lead = 0.5;
  // While flying, the plan's tail is replanned whenever the tracker's
  // prediction of the target at the plan's arrival differs from the plan's
  // by more than target_replan_threshold m (its position, and its heading
  // times the base's distance from it), at most every
  // target_replan_interval s: from the plan's own state at
  // max(now + replan_lead, arrival - target_tail) to the target as now
  // predicted, spliced there without a blend (the two plans meet exactly),
  // until the shift below begins.
  // The head stays as it was certified; a tail replan that fails keeps the
  // plan. The tracking-error replans (replan_threshold) still start from
  // the measured state; the periodic ones are not made (a moving target's
  // replans come from its prediction).
  double target_replan_threshold = 0.005;
  double target_replan_slope = 0.01;  // m per s left to the arrival, added to the threshold
  double target_tail = 3.0;
  // From half a second before the insertion (and while following after the
  // arrival), the setpoints are shifted by where the tracker has the target
  // now less where the plan's prediction has it (and the velocities by the
  // difference of their velocities), blended in over that half second: the
  // prediction's last error, which a replan this late could not fix
  // (Replan's begun insertion must keep the tool on the line from its first
  // sample). Relative to the target the robot then moves as planned; against
  // the still scene it moves by the shift, which is therefore at most
  // target_correction m and at most what the still scene leaves the rest of
  // the plan and the follow over the accepted clearance (0: no shift).
  double target_correction = 0.05;
  // With target_settle, a goal with an insertion is approached in two
  // plans: the first to the insertion's start (the tool backed off along
  // the line), arriving at rest relative to the target; the vehicle then
  // follows the target there until the measured tool is within
  // target_settle_tolerance m of that point and its speed within 2 cm/s of
  // the target's (or target_settle_timeout s have passed), and the second
  // plan, from that state moving with the target, makes the insertion. A
  // vehicle that has just matched the target's speed is centimetres off
  // its reference, and the insertion's fingers leave millimetres.
  bool target_settle = true;
  double target_settle_tolerance = 0.003;
  double target_settle_timeout = 2.0;
  double target_replan_interval = 0.2;
  // No target measurement for this long (s) while flying: the target is
  // lost, and the flight ends holding (HoldCause::kTargetLost); so does a
  // flight with no estimate of it connect_timeout s after the vehicle was
  // offboard and armed.
  double target_timeout = 1.0;
  // At the arrival the vehicle follows the target for arrival_hold s (the
  // plan's end state moved on with the plan's prediction; the path
  // checked first against the still scene and cut short where it would
  // come under the safety distance less the tolerance), then finishes.
  // It has settled when the measured tool was within
  // target_arrival_tolerance m of the tracker's target at the arrival.
  // The abort near the goal and the tool trim are not used for a moving
  // target (the retreat along the plan would go where the target was).
  double target_arrival_tolerance = 0.01;

  bool IsValid(std::string* why) const;
};

enum class Phase {
  kWaitingForVehicle,
  kStreamingHold,
  kRequestingOffboard,
  kArming,
  kWaitingForPlan,
  kFlying,
  kArrived,
  kHoldingAfterFailure,
  kVehicleLost,
  kHandshakeFailed,
};
const char* PhaseName(Phase phase);  // "streaming_hold", ...

// Why the flight ended in Phase::kHoldingAfterFailure.
enum class HoldCause {
  kNone,
  kPlanFailed,       // the first plan, a replan or a resume failed or failed its check
  kLinkFailed,       // a mission's link hold (a mission is not resumed)
  kToolNotSettled,   // a mission's tool did not settle at a junction or a gripper step
  kGripperFailed,    // the gripper command was refused or not acknowledged
  kTargetLost,       // a moving target was not measured for target_timeout
};
const char* HoldCauseName(HoldCause cause);  // "the plan failed", ...

// kGripper: MAV_CMD_DO_GRIPPER at a mission's grasp or release.
enum class Command { kSetOffboardMode, kArm, kGripper };
struct CommandRequest {
  Command command = Command::kSetOffboardMode;
  int attempt = 0;  // 0 first, then 1, 2, ... (MAVLink's confirmation field)
  bool grab = false;  // kGripper: grab (close) or release (open)
};

// How an acknowledgement answered a command.
enum class AckResult { kAccepted, kTemporarilyRejected, kRejected };

// The autopilot's flight mode as its heartbeat gives it (PX4 custom modes):
// what the vehicle does when quadhand-online does not steer it.
enum class AutopilotMode { kUnknown, kOffboard, kPosition, kHold, kLand, kOther };
const char* AutopilotModeName(AutopilotMode mode);  // "OFFBOARD", "POSITION", "HOLD", "LAND", ...

// The latest measurements, ENU/FLU (what the controller plans from).
struct MeasuredState {
  double time = 0.0;  // controller time of the position
  Vec3 position = Vec3::Zero();
  Vec3 velocity = Vec3::Zero();
  Quat attitude = Quat::Identity();
  Vec3 body_rate = Vec3::Zero();
  VecX joints, joint_rates;
};

// Distance of the tool frame at a measured state (base pose and joints,
// forward kinematics) from the task's goal.tool.position; none when the task
// has no tool goal, the robot lacks its tool_link or the joints are missing.
// The arrival hold waits on it and the flight log reports it.
std::optional<double> ToolGoalError(const robot::RobotModel& robot, const planner::Task& task,
                                    const MeasuredState& state);

// The exact clearance of a measured state (its base pose and joints, the
// link meshes against the scene's points), searched out to `reach`: what
// the flight's verdict judges each state by and what the abort near the
// goal watches. `kinematics` receives the state's forward kinematics;
// `link` (optional) gets the closest link.
double MeasuredClearance(const robot::RobotModel& robot, const env::ExactMeshModel& exact, const MeasuredState& state,
                         double reach, robot::KinematicsState* kinematics, int* link = nullptr);
// The same with a moving target: against the still scene `exact` and the
// moving points `moving` (their model at the target's pose in the task,
// `task_target`; null: none) where `target` has the target (none: at its
// pose in the task, as before a tracker's first estimate).
double MeasuredClearance(const robot::RobotModel& robot, const env::ExactMeshModel& exact,
                         const env::ExactMeshModel* moving, const Pose& task_target, const std::optional<Pose>& target,
                         const MeasuredState& state, double reach, int* link = nullptr);

// Flying on a sensor (quadhand-online --perception; docs/perception.md,
// "Flying online on the sensor"): every plan is a local plan
// (explore/local_planner.h) from a rolling map of the frames OnSensorFrame
// is given, never from the setup's scene.
//   - Frames pass the gate (perception/sensor_frame.h) on the controller's
//     clock (their vehicle stamps mapped by the clock sync) and go into the
//     map at once.
//   - The first plan waits for min_frames frames; a first plan that fails
//     is asked again every replan_period.
//   - Every replan_period while flying a plan to a local target (not once a
//     plan to the goal is flown), a local plan from the flown plan's own
//     state replan_lead ahead, spliced there exactly when it comes in time
//     (a late one is dropped). One that fails keeps the flown plan, which
//     ends at rest inside seen free space; at its end the vehicle holds and
//     the replans go on from there. A plan to a local target ending is not
//     an arrival.
//   - The voxels a frame turns from free to occupied are checked against
//     the plan flown (and the first plan, and a plan coming from the
//     worker, against those since it was asked) at the planned safety
//     distance (LocalPlanner::FirstConflict): a flown plan crossing them
//     brakes along its path (the link hold's brake) and a fresh plan is
//     made from the measured state at rest; the others are dropped.
//   - No frame taken for sensor_timeout: the same brake, and no plan until
//     frames are taken again.
//   - No plan begun for stuck_time while the vehicle holds: the flight
//     ends holding (HoldCause::kPlanFailed).
// The flight's verdict is against what the sensor saw (SeenPoints()):
// in simulation quadhand-flightcheck judges it against the true world.
struct PerceptionSetup {
  const explore::LocalPlanner* planner = nullptr;  // null: no perception (the setup's scene)
  perception::RollingMapOptions map;
  // A prior map (RollingMap::SetPrior; quadhand-online: the task's scene):
  // obstacles where the sensor has seen nothing, set when the vehicle is
  // first held. It frees no space.
  std::shared_ptr<const std::vector<Vec3>> prior;
  perception::FrameGateOptions gate;
  double sensor_timeout = 0.3;     // s
  double start_free_radius = 0.8;  // m of free space about the vehicle when it is first held
  int min_frames = 3;
  double replan_period = 0.5;      // s
  double stuck_time = 15.0;        // s
  // SeenPoints(): the map's last word on each voxel, merged every
  // seen_period s of frames.
  double seen_period = 1.0;
  bool IsValid(std::string* why) const;
};

// What the planner needs; the scene, task and solver must outlive the controller.
struct PlanningSetup {
  planner::PlanningScene scene;
  const planner::Task* task = nullptr;  // goal, limits, safety distance (its start is replaced)
  planner::PlannerOptions plan_options = planner::DefaultPlannerOptions();
  planner::ReplanOptions replan_options = planner::DefaultReplanOptions();
  const opt::Solver* solver = nullptr;
  // For a task with a mission of more than one step: the context its phases
  // are built from (planner::PlanTask) and a cache for them; the mission is
  // flown without replans, its gripper commanded at each grasp and release.
  const planner::PlanningContext* context = nullptr;
  planner::MissionPhaseCache* mission_phases = nullptr;
  // Flying on a sensor; the LocalPlanner must outlive the controller.
  PerceptionSetup perception{};
};

// One planning run, as the worker reports it.
struct PlanRecord {
  double requested_at = 0.0;  // controller time
  bool replan = false;
  bool periodic = false;      // replans: started by replan_period, not by the threshold
  bool success = false;
  // A periodic replan certified but dropped: its plan takes more than
  // replan_options.max_rejoin_stretch times what is left of the current
  // plan (or its horizon, when longer). On track, the current plan is still
  // certified; a far slower one from there is a detour (docs/online.md).
  bool dropped_as_slower = false;
  planner::PlanStatus status = planner::PlanStatus::kInvalidInput;  // kInvalidInput: Plan()/Replan() refused the request
  std::string message;
  double latency_ms = 0.0;    // wall time of Plan()/Replan() (both, with a cold fallback)
  double warm_ms = 0.0;       // replans: the warm-started Replan() alone
  bool cold_fallback = false; // replans: the warm start failed and a cold plan was made
  // Replans: the start was inside the safety margin and the plan was judged
  // by the recovery rule (planner/replan.h); start_clearance is its exact
  // clearance (m, negative inside the scene).
  bool recovery = false;
  double start_clearance = 0.0;
  double solve_ms = 0.0;
  int iterations = 0;
  double speed_limit = 0.0;   // v_max it was planned with (m/s: the task's, or lower for the link)
  double slowdown = 1.0;      // plans from rest: the factor it was slowed down by for the link
  // A moving target: the plan's prediction (time of its t = 0, and the
  // ms spent building the moving points' models for it, in latency_ms).
  bool moving_target = false;
  double prediction_ms = 0.0;
  // A moving target approached in two plans (OnlineOptions::target_settle):
  // this is the first (to the insertion's start), or the second (the
  // insertion, from above the target).
  bool pre_grasp = false, from_settled = false;
  // A local plan (PerceptionSetup): its explore::LocalPlanStatus (-1: not a
  // local plan), the boundary planned against and the map snapshot's ms
  // (in latency_ms).
  int local_status = -1;
  size_t scene_points = 0;
  double snapshot_ms = 0.0;
};

// Flying on a sensor (PerceptionSetup).
struct PerceptionStats {
  perception::FrameCounts frames;     // the gate's: taken, and dropped by reason
  long empty_frames = 0;
  std::vector<double> map_update_ms;  // per frame taken (the window's move included)
  size_t peak_map_bytes = 0;          // sampled every 30 frames
  int silences = 0;                   // times the sensor went silent
  int sensor_brakes = 0;              // brakes for a silence or a conflict while flying
  int conflicts = 0;                  // new obstacles across a plan (flown, first, or coming)
  int flown_conflicts = 0;            // of them, across the plan flown (it braked)
  int late_plans = 0;                 // local replans that came after their splice (dropped)
  long map_overrun = 0;               // frames dropped waiting for the map (it was behind)
  size_t seen_points = 0;             // SeenPoints() at the last merge
};

struct OnlineStats {
  long setpoints = 0;
  long position_measurements = 0;
  std::vector<PlanRecord> plans;       // every plan and replan, in order
  int replans_triggered = 0;          // by the threshold and periodic
  int periodic_replans = 0;
  int splices = 0;
  double max_tracking_error = 0.0;     // m, while flying
  double sum_tracking_error = 0.0;     // over flying measurements (mean = sum / count)
  double sum_squared_tracking_error = 0.0;
  long tracking_samples = 0;
  double max_setpoint_step = 0.0;      // m between consecutive streamed setpoints
  double max_splice_step = 0.0;        // m, the same during blend windows
  // The same steps divided by the time between the ticks (m/s): unlike the
  // steps, not inflated when a tick comes late on a busy machine.
  double max_setpoint_speed = 0.0;
  double max_splice_speed = 0.0;
  // Time and the link.
  long stale_states_dropped = 0;       // arrived after a newer one (reordered, duplicated)
  double max_state_age = 0.0;          // s, largest age of a state at its arrival
  double sum_state_age = 0.0;          // over position_measurements
  int link_holds = 0;                  // holds waiting for the link
  int link_resumes = 0;                // fresh plans after such a hold
  int replans_skipped_stale = 0;       // triggers refused: the newest state was too old
  int reengagements = 0;               // OFFBOARD requested again after the autopilot's failsafe
  // The estimate's jumps (OnlineOptions::innovation_gate): how many, their
  // sizes summed (m, each the innovation beyond what the motion explains)
  // and the largest, with its controller time.
  int estimate_jumps = 0;
  double estimate_jump_sum = 0.0;
  double largest_estimate_jump = 0.0;
  double largest_estimate_jump_time = 0.0;
  // The jumps summed as vectors (m): the estimate less this is the frame
  // the flight is judged in, and the setpoints were streamed plus it
  // (zero unless OnlineOptions::shift_setpoints_on_jump).
  Vec3 estimate_shift = Vec3::Zero();
  // A moving target's measurements: used, dropped (older than the newest,
  // older than max_target_age on arrival, or malformed) and rejected by
  // the tracker's gate; its restarts; replans its prediction triggered.
  long target_measurements = 0;
  long target_dropped_stale = 0;
  long target_dropped_malformed = 0;
  long target_rejected = 0;
  int target_restarts = 0;
  int target_replans = 0;
  // The measured tool's distance from the tracker's target at the arrival
  // (the first state at or after the plan's end) and the most while
  // following it after (m; NaN before the arrival / without a target).
  double arrival_target_error = std::numeric_limits<double>::quiet_NaN();
  double max_follow_target_error = std::numeric_limits<double>::quiet_NaN();
  PerceptionStats perception;
};

// Controller time -> plan time of a mission flown with the waits at its
// junctions (OnlineOptions::junction_tolerance) and its link holds
// (OnlineOptions::resume_tolerance): t - start, less the time the plan's
// clock stood still before t. `pauses`: (plan time, seconds) in order of
// plan time. A link hold's pause is at the start of the leg it happened in:
// the leg flown up to the hold, the brake, the stand-still and the way back
// to the leg's start are mapped as a stand-still there, then the leg again
// - within the same leg, so with the same geometry (a hold stops before
// the next junction).
struct PlanClock {
  double start = 0.0;
  std::vector<std::pair<double, double>> pauses;
  double PlanTime(double t) const;
  // The controller time the plan left plan time `plan_time` (after a pause there).
  double TimeLeaving(double plan_time) const;
  // A pause at `plan_time` (the last one, when it is already there), for
  // the caller to grow.
  void PauseAt(double plan_time);
};

struct ControllerOutput {
  std::optional<Setpoint> setpoint;      // stream this now (none: stream nothing)
  std::vector<CommandRequest> commands;  // send these now
  bool send_heartbeat = false;
  std::optional<int64_t> timesync_request;  // send TIMESYNC (tc1 0, ts1 this: ns of our clock)
  std::vector<std::string> events;       // what happened, in words, for the operator
  Phase phase = Phase::kWaitingForVehicle;
};

class PerceptionMap;

class OnlineController {
 public:
  static core::Result<std::unique_ptr<OnlineController>> Create(const PlanningSetup& setup,
                                                                const OnlineOptions& options);
  ~OnlineController();
  OnlineController(const OnlineController&) = delete;
  OnlineController& operator=(const OnlineController&) = delete;

  // Measurements at controller time t (s), ENU/FLU: the time the vehicle
  // took them (MeasurementTime()), not when they arrived. One older than or
  // as old as the newest of its kind is dropped (reordered or duplicated).
  // `vehicle_time` (s, the vehicle's own stamp; NaN: t) times the
  // innovation gate's prediction: the mapping to controller time moves
  // when the clock estimate is refined, and a step of 10 ms in it would
  // read as 7 mm of innovation at 0.7 m/s. `position` is the vehicle's
  // estimate; the controller keeps it less stats().estimate_shift.
  void OnPosition(double t, const Vec3& position, const Vec3& velocity,
                  double vehicle_time = std::numeric_limits<double>::quiet_NaN());
  void OnAttitude(double t, const Quat& attitude, const Vec3& body_rate);
  void OnJoints(double t, const VecX& joints, const VecX& joint_rates);
  // Where each servo is commanded to (its goal register), when the vehicle
  // reports it: a servo whose goal stands still while the plan moves it was
  // not told to move (the uplink's setpoints are late or lost), and its
  // joint standing still is not a stall.
  void OnJointGoals(double t, const VecX& goals);
  const VecX& joint_goals() const { return joint_goals_; }  // empty until reported
  // A moving target's measured pose (LANDING_TARGET, mavlink_bridge.h):
  // its position and heading at controller time t (the vehicle's stamp
  // mapped), `age` s old on arrival. Dropped (and counted) when the task's
  // target does not move, when older than max_target_age, or when not
  // newer than the newest; else filtered (target_tracker.h).
  void OnTarget(double t, const Vec3& position, double yaw, double age);
  // A target message that could not be read (counted, never used).
  void OnMalformedTarget() { ++stats_.target_dropped_malformed; }
  bool tracks_target() const { return tracker_ != nullptr; }
  // The tracker's estimate of the target at t as the pose of the task's
  // tool goal (where the tool must be); none before it has one.
  std::optional<Pose> TargetPoseAt(double t) const;
  // A sensor frame (PerceptionSetup) received at controller time t,
  // stamped frame.t on the vehicle's clock, its points and misses in the
  // sensor's frame. Ignored without perception.
  void OnSensorFrame(double t, perception::SensorFrame frame);
  bool perceiving() const { return setup_.perception.planner != nullptr; }
  // What the sensor saw occupied over the flight: the raw returns of every
  // voxel the map last saw occupied (merged every seen_period s of frames
  // and now; a voxel later seen free has none, one that left the window
  // keeps its last): what a perception flight is judged against. Waits for the frames given to be mapped, and
  // brings stats().perception's map figures up to date.
  std::vector<Vec3> SeenPoints();
  // Waits until the frames given are in the map (tests).
  void WaitForMap();
  // The vehicle's heartbeat: armed flag and whether it is in OFFBOARD.
  void OnHeartbeat(double t, bool armed, bool offboard);
  // The mode the same heartbeat gives: each change is an event, so that
  // the log says what the autopilot did (a failsafe's hold or land).
  void OnAutopilotMode(double t, AutopilotMode mode, bool armed);
  AutopilotMode autopilot_mode() const { return autopilot_mode_; }
  bool autopilot_armed() const { return vehicle_armed_; }
  void OnCommandAck(double t, Command command, AckResult result);
  // A TIMESYNC answer (tc1: the vehicle's ns, ts1: ours) arrived at t.
  void OnTimesync(double t, int64_t tc1, int64_t ts1);
  // Our time of a state the vehicle stamped `vehicle_time` (s of its clock)
  // that arrived at `received`: the stamp mapped by the clock sync, never
  // later than the arrival; the arrival time while the clock is not synced.
  double MeasurementTime(double received, double vehicle_time) const;
  const ClockSync& clock_sync() const { return clock_; }

  // What to send at time t (call at the streaming rate, t non-decreasing).
  ControllerOutput Tick(double t);

  Phase phase() const { return phase_; }
  int num_joints() const { return setup_.scene.robot.num_actuated(); }
  bool finished() const;  // arrived and held, or a phase that ends the flight
  // The flight was aborted: near the goal (a retreat along the plan), or
  // for a stalled joint.
  bool aborted() const { return aborted_; }
  // The abort was a joint that stopped following the plan (a brake along
  // the plan, no retreat).
  bool joint_stalled() const { return joint_stalled_; }
  // In Phase::kHoldingAfterFailure: why (kNone in any other phase).
  HoldCause hold_cause() const { return hold_cause_; }
  // After finished() in the arrived phase: whether the vehicle settled at the
  // goal (false: arrival_timeout passed first).
  bool arrival_settled() const { return arrival_settled_; }
  const OnlineStats& stats() const { return stats_; }
  // The plan being flown (null before the first plan).
  std::shared_ptr<const planner::PlanResult> current_plan() const { return to_.plan; }
  // Time offset of the current plan: plan time = t - current_plan_start()
  // (for a mission, from now on: plan_clock() maps the whole flight).
  double current_plan_start() const { return to_.start; }
  // A mission's plan clock: where it stood still at junctions.
  const PlanClock& plan_clock() const { return plan_clock_; }
  // The plan time the vehicle was at when the flight failed while flying
  // the plan (it holds there since); negative when it did not.
  double failed_plan_time() const { return failed_plan_time_; }
  // The latest measurements (meaningful once a position, attitude and joints arrived).
  MeasuredState measured() const;
  bool has_measured_state() const { return HaveState(); }
  // The last setpoint Tick() returned (none before the first).
  const std::optional<Setpoint>& last_setpoint() const { return last_setpoint_; }
  // What the last setpoint's position was shifted by when it was sent,
  // besides an estimate jump's shift: the tool trim and a moving target's
  // last correction.
  const Vec3& last_setpoint_shift() const { return last_setpoint_shift_; }
  // How far ahead of its sending time a setpoint is sampled (s,
  // OnlineOptions::setpoint_lead).
  double SetpointLead() const;
  // The reference at time t while flying (blended during a splice).
  std::optional<Setpoint> Reference(double t) const;
  // The reference the vehicle was following at time t: the one we streamed
  // an uplink latency earlier.
  std::optional<Setpoint> ReferenceFollowedAt(double t) const;
  // The speed limit the link allows now (m/s; infinite without a known latency).
  double LinkSpeedLimit(double t) const;

  // For tests and tools: whether the worker is planning, and waiting for it.
  bool planning() const;
  void WaitUntilIdle();

 private:
  struct ActivePlan {
    std::shared_ptr<const planner::PlanResult> plan;
    double start = 0.0;  // controller time of the plan's t = 0
    // A moving target: the prediction it was planned against (its motion's
    // clock is the plan's); the plan's setpoints after its end follow it.
    std::shared_ptr<const planner::MovingSceneModels> target;
    // Perception: a plan to a local target, whose end is not an arrival.
    bool to_local_target = false;
  };
  // Perception (controller_perception.cc): the sensor's silence, the new
  // obstacles the map found, the resume after a brake for the sensor and
  // the stuck flight (each tick); the plans new obstacles cross; whether a
  // new plan crosses what was seen since it was asked.
  void CheckSensor(double t);
  bool SensorSilent(double t) const;
  void CheckNewObstacles(double t, const std::vector<Vec3>& blocked);
  bool CrossesSeenSinceAsked(const planner::PlanResult& plan) const;
  double PerceptionReplanPeriod() const;
  // Brakes along the plan for the sensor (a silence, new obstacles), counted;
  // returns the speed it brakes from.
  double BrakeForSensor(double t);
  // After a brake for the sensor: a local plan from the measured state at
  // rest, once the vehicle holds.
  void RequestFreshLocalPlan(double t);
  // A replan handed to the worker, to be spliced at `splice_time` (`exact`:
  // without a blend; `keep_from`: the plan flown now stays from_): counted.
  void MarkReplanPending(double splice_time, bool exact, bool keep_from);
  // A local replan from the plan flown, its state replan_lead ahead
  // (`exact`: spliced there), or from the measured state predicted there.
  void RequestLocalReplan(double t, bool exact, double error);
  // The setpoint of `plan` at controller time t (after a moving target's
  // plan has ended: its end state following the prediction).
  static Setpoint SampleActive(const ActivePlan& plan, double t);
  // The measured state predicted to plan time `plan_time` of `flown` (a
  // replan's start off track), the tracking error held constant.
  planner::BoundaryState PredictedMeasuredState(const ActivePlan& flown, double plan_time) const;
  // The measured pose and joints at rest: a fresh plan's start after a hold.
  planner::BoundaryState MeasuredStateAtRest() const;
  // A moving target (controller_target.cc): the prediction from time t as
  // a job's motion and placement; false without an estimate.
  bool PredictTarget(double t, std::optional<planner::TargetMotion>* motion, Pose* placement) const;
  // The replan its prediction calls for (target_replan_threshold).
  void CheckTarget(double t);
  // The predicted target at the current plan's arrival less the plan's.
  double ArrivalShift() const;
  // The measured tool's distance from the tracker's target now.
  double ToolTargetError() const;
  // The follow's configuration at plan time `plan_time` (past the plan's
  // end), level, with the other fields of the measured state.
  MeasuredState FollowState(const ActivePlan& plan, double plan_time) const;
  // Setpoint `s`'s configuration, level (a follow does not accelerate), with
  // the other fields of the measured state: what a follow or a retreat with
  // the target is checked by.
  MeasuredState LevelStateOf(const Setpoint& s) const;
  // How long the follow after the current plan's end keeps its clearance
  // against the still scene (at most `longest` s).
  double ClearFollowDuration(double longest) const;
  // `retreat` (the plan's setpoint at plan time `tau` run backwards, its
  // clock at `rate` and `rate_change`; `plan_velocity` the plan's own
  // velocity there) carried with the target from where the plan predicted
  // it at `tau` to where the tracker has it at t.
  void CarryWithTarget(double t, double tau, const Vec3& plan_velocity, double rate, double rate_change,
                       Setpoint* retreat) const;
  // Whether the retreat keeps the clearance against the still scene, as the
  // target is predicted now (the moving points go with the robot); sets how
  // long the follow after it does (retreat_hold_, at most abort_hold).
  bool RetreatWithTargetIsClear(double t);
  // The task's tool goal where an estimate has the target.
  Pose TargetPoseOf(const TargetEstimate& estimate) const;
  // Where `plan`'s prediction has the target (the tool goal's pose) at plan
  // time `plan_time`.
  static Pose PlannedTarget(const ActivePlan& plan, double plan_time);
  // The shift of the setpoints at t (OnlineOptions::target_correction):
  // position and velocity, zero outside the insertion and the follow.
  void TargetCorrection(double t, Vec3* position, Vec3* velocity);
  class Worker;

  OnlineController(const PlanningSetup& setup, const OnlineOptions& options);
  bool HaveState() const;
  // Distance of the measured tool frame from the task's tool goal (a
  // mission: from the plan's last tool pose; neither: of the base from the
  // plan's last setpoint).
  double ArrivalOffset() const;
  void Event(std::string text);
  void CollectPlan(double t);
  // A mission's gripper: the command of each grasp and release as its step
  // begins, resent until acknowledged.
  void CommandGripper(double t, ControllerOutput* out);
  bool IsMission() const { return !planner::PlansAsGoal(*setup_.task); }
  // A mission's wait at the junction of its legs that the plan has reached
  // (OnlineOptions::junction_tolerance): stops the plan's clock there until
  // the vehicle has settled, or fails after junction_timeout.
  void WaitAtJunction(double t);
  // How far the measured tool is from where the current plan has it at
  // `plan_time` (0 without a tool link or a complete state).
  double ToolOffPlan(double plan_time) const { return ToolOffsetFromPlan(plan_time).norm(); }
  // The measured tool less the planned one at `plan_time` (zero as above).
  Vec3 ToolOffsetFromPlan(double plan_time) const;
  // The tool frame's position at the measured base pose and joints (needs
  // a complete state and the tool link).
  Vec3 MeasuredTool() const;
  // The same with the plan's base at the measured attitude: where the plan
  // is not at rest its attitude tilts with its acceleration, and a vehicle
  // holding there cannot tilt so (a mission's link hold).
  double ToolOffPlanAtRest(double plan_time) const;
  // A replan from the measured state at t; `periodic`: started by
  // replan_period with the tracking error below the threshold.
  void MaybeReplan(double t, bool periodic, double error);
  // A moving target's replan of the current plan's tail (controller_target.cc).
  void ReplanTail(double t, double shift);
  // A tail replan has been spliced in and waits for its start (t before it).
  bool PendingTailSplice(double t) const { return blending_ && splice_window_ <= 0.0 && t < blend_start_; }
  // At a tick: replans due from the newest state, and the link budget.
  void CheckTracking(double t);
  void CheckLink(double t, ControllerOutput* out);
  void RequestFirstPlan(double t);
  double UplinkLatency() const;     // s, 0 without a synced clock
  double BlindTime(double t) const; // age of the newest state + uplink (median)
  double PlanningSpeedLimit() const;
  // The setpoint while braking for the link: the plan's path, its clock
  // slowing to a stop over link_brake_duration_.
  std::optional<Setpoint> LinkHoldReference(double t) const;
  // A mission's link hold (OnlineOptions::resume_tolerance): its start, the
  // clock's plan time, rate and rate of change at t, the setpoint, and what
  // each tick does (keeps to_.start and the plan clock on the warped clock,
  // resumes when it can).
  void StartMissionHold(double t);
  void MissionHoldClock(double t, double* plan_time, double* rate, double* rate_change) const;
  std::optional<Setpoint> MissionHoldReference(double t) const;
  void HoldMission(double t, ControllerOutput* out);
  // Whether the link was good for the whole clock window before t: no
  // blind time over max_blind_time, and no gap between TIMESYNC answers
  // longer than that (the uplink).
  bool LinkGoodOverWindow(double t) const;
  // After the autopilot's failsafe: once the setpoints (a hold) have been
  // streamed for hold_time, OFFBOARD is requested until confirmed (true
  // then; the handshake's retries and failure as for the first).
  bool ReengageOffboard(double t, ControllerOutput* out);
  // Begins that re-engagement (the handshake's state, counted).
  void StartReengagement(double t);
  // Plan time of the next junction of a mission's legs (its end after the
  // last), and of the start of the leg being flown.
  double NextJunctionTime() const;
  double LegStartTime() const;
  // Makes t - to_.start read `plan_time`: the difference goes to the plan
  // clock's last pause (a junction's wait, a mission's link hold).
  void SetPlanTime(double t, double plan_time);
  // A link hold: the brake along the plan (a mission's warped clock too), counted.
  void HoldForLink(double t, double speed);
  // The least margin over the safety distance less the tolerance (the
  // robot's, and the held object's bound) of the configurations between
  // the measured one and the plan's at plan_time, with the base and the
  // arm each anywhere along its straight move (a grid): the move OFFBOARD
  // makes to rejoin a mission after the autopilot's failsafe.
  double RejoinMargin(double plan_time) const;
  // The margin over the safety distance less the tolerance of one
  // whole-body configuration flown at plan_time: the robot of that time's
  // mission leg with its held object's bound, or the task's robot; `link`
  // gets the robot's nearest link.
  double ConfigurationMargin(double plan_time, const MeasuredState& state, int* link) const;
  double ConfigurationMargin(const planner::MissionLeg* leg, const MeasuredState& state, int* link) const;
  // While waiting at the junction at plan time `junction` (or holding at
  // the goal, the plan's end): updates
  // tool_trim_ towards the tool's planned pose (OnlineOptions::tool_trim).
  void TrimTool(double t, double junction);
  // The least ConfigurationMargin of the plan's configuration at the
  // junction and of the whole next leg with the base shifted by `trim`.
  double TrimmedMargin(const Vec3& trim, double junction) const;
  // "the base's setpoints shifted by X m ...", for the settled events.
  std::string TrimWords() const;
  // The least ConfigurationMargin along the plan from plan time `from` to
  // `to`, the base shifted by `shift` and the joints in `held` at their
  // measured angles (the rest as planned), judged with `leg` (null: each
  // time's own leg), and the plan time and link of it (either may be
  // null): the path a stuck joint leaves ahead, a trimmed leg.
  double PathMargin(double from, double to, const Vec3& shift, const std::vector<int>& held,
                    const planner::MissionLeg* leg, double* at, int* link) const;
  // Of the joints standing still off the plan at plan time `at` (each with
  // how far off), the one farthest off when the plan ahead with them where
  // they stand comes too close within the brake's path and the detection's
  // delay (`lag`: the servo window plus the uplink), `words` saying where;
  // -1 when none does.
  int StuckJointAhead(double t, double at, double lag, const std::vector<std::pair<int, double>>& stuck,
                      std::string* words) const;
  void Fail(Phase phase, const std::string& why, HoldCause cause = HoldCause::kNone);
  planner::BoundaryState MeasuredBoundaryState() const;
  void RunHandshake(double t, ControllerOutput* out);
  // Sends `command` (attempt attempts_) unless `confirmed`, retrying every
  // ack_timeout up to max_command_attempts (then handshake_failed, "no
  // <name> acknowledgement"); true once confirmed.
  bool CommandUntilConfirmed(double t, Command command, bool confirmed, const std::string& name,
                             ControllerOutput* out);

  PlanningSetup setup_;
  OnlineOptions options_;
  std::unique_ptr<Worker> worker_;
  Phase phase_ = Phase::kWaitingForVehicle;
  std::vector<std::string> events_;

  // Latest measurements.
  bool have_position_ = false, have_attitude_ = false, have_joints_ = false;
  double position_time_ = 0.0;
  double position_vehicle_time_ = 0.0;  // the newest position's own stamp (OnPosition)
  Vec3 position_ = Vec3::Zero(), velocity_ = Vec3::Zero();
  Quat attitude_ = Quat::Identity();
  Vec3 body_rate_ = Vec3::Zero();
  VecX joints_, joint_rates_;
  double attitude_time_ = -1e300, joints_time_ = -1e300;
  bool vehicle_armed_ = false, vehicle_offboard_ = false, seen_heartbeat_ = false;
  AutopilotMode autopilot_mode_ = AutopilotMode::kUnknown;
  ClockSync clock_;
  bool position_checked_ = true;    // the newest position was looked at by CheckTracking
  bool age_noted_ = true;           // the newest position's age is in the stats
  double last_error_ = 0.0;         // tracking error of the newest position
  double last_velocity_error_ = 0.0;  // m/s, of the newest velocity against the reference's
  double planned_speed_limit_ = 0.0;  // v_max of the plan being flown (the task's, or the link's)
  int tool_link_ = -1;                 // the task's tool link in the robot (-1: none)
  bool link_hold_ = false;          // braking / holding for the link (phase flying)
  // A mission's link hold (HoldMission): plan times of the brake's start
  // and of the stop, the controller time the way back to the leg's start
  // began (< 0: not yet) and its length, the plan's top speed from the
  // stop on.
  bool mission_hold_ = false;
  double mission_brake_from_ = 0.0, mission_stop_time_ = 0.0;
  double mission_resume_start_ = -1.0, mission_ramp_duration_ = 0.0;
  double mission_leg_start_ = 0.0;  // plan time the leg being resumed began (at rest)
  double mission_hold_speed_ = 0.0;
  bool mission_slow_link_noted_ = false;
  bool rejoin_checked_ = false;
  double link_hold_start_ = 0.0;
  double link_brake_duration_ = 1.0;
  std::deque<std::pair<double, double>> blind_history_;  // (tick time, blind time)
  bool first_plan_requested_ = false;
  bool waiting_for_link_noted_ = false;

  // Handshake.
  double hold_start_ = 0.0;
  Setpoint hold_;
  Command pending_command_ = Command::kSetOffboardMode;
  int attempts_ = 0;
  double last_command_time_ = 0.0;
  double confirmed_time_ = 0.0;  // when OFFBOARD and arming were both confirmed
  double first_tick_ = 0.0;
  bool ticked_ = false;
  bool arrival_done_ = false;
  bool offboard_confirmed_ = false, armed_confirmed_ = false;
  double next_heartbeat_ = 0.0;

  // Plans.
  std::shared_ptr<const planner::PlanResult> first_plan_;
  ActivePlan from_, to_;          // blending from_ -> to_ during [blend_start_, blend_start_ + window)
  bool blending_ = false;
  double blend_start_ = 0.0;
  double last_trigger_ = -1e300;
  bool replan_pending_ = false;
  double pending_splice_time_ = 0.0;
  bool pending_resume_ = false;        // the pending plan resumes after a link hold
  // The autopilot left OFFBOARD during a link hold (its failsafe): the
  // handshake is run again before the fresh plan (OutageTimeout).
  bool left_offboard_in_outage_ = false;
  bool reengaging_ = false;             // that handshake is under way
  bool hold_until_resume_ = false;      // stream hold_ (not the braked plan) until the fresh plan flies
  // An abort (OnlineOptions::abort_near_goal, CheckJointStall): the start
  // (controller time) and duration of its motion (the retreat, or a stalled
  // joint's brake), the retreat's plan times from and to; aborted_ once it
  // has begun, abort_done_ after the hold that follows.
  bool retreating_ = false, aborted_ = false, abort_done_ = false, joint_stalled_ = false;
  HoldCause hold_cause_ = HoldCause::kNone;
  double retreat_start_ = 0.0, retreat_from_ = 0.0, retreat_to_ = 0.0, retreat_duration_ = 1.0;
  double abort_checked_time_ = -1.0;  // the newest state CheckAbort measured
  // CheckJointStall: the newest joint state looked at, and since when (its
  // time) some joint has not followed the plan; -1: none.
  double stall_checked_time_ = -1.0;
  double stall_since_ = -1.0;
  // OnJointGoals: the servos' goals and their time (negative: none yet).
  VecX joint_goals_, goal_moved_time_;  // and when each last changed
  double joint_goals_time_ = -1.0;
  // A joint that stopped while the plan moved it: brakes along the plan,
  // holds and ends the flight aborted.
  void CheckJointStall(double t);
  // Starts braking along the current plan from `speed` (m/s) at t: a slow
  // link's hold, a stalled joint's abort.
  void BrakeAlongPlan(double t, double speed);
  // How long that brake takes from `speed`: half the task's acceleration
  // limit on average, at least 0.2 s.
  double BrakeDuration(double speed) const;
  void CheckAbort(double t);
  // A hold (every rate zero) at the newest measured position, yaw and joints.
  Setpoint HoldAtMeasuredPose() const;
  Setpoint RetreatReference(double t) const;
  bool outage_noted_ = false;           // the wait beyond vehicle_timeout was announced
  std::shared_ptr<const planner::PlanResult> pending_base_;  // the plan the pending replan started from
  double arrival_time_ = 0.0;
  bool arrival_settled_ = false;
  double failed_plan_time_ = -1.0;  // failed_plan_time()
  // The mission's gripper: the next grasp or release step to command, the
  // one sent and not yet acknowledged (-1: none), when and how often.
  size_t next_gripper_step_ = 0;
  long gripper_pending_ = -1;
  double gripper_sent_at_ = 0.0;
  int gripper_attempts_ = 0;
  // The mission's next junction (index of the leg it ends), when the wait
  // there began (negative: not waiting), and where its clock stood still.
  size_t next_junction_ = 0;
  double junction_wait_start_ = -1.0;
  // TrimTool's shift of the base's setpoints (world frame) and its last update.
  Vec3 tool_trim_ = Vec3::Zero();
  Vec3 last_setpoint_shift_ = Vec3::Zero();  // last_setpoint_shift()
  // The streaming period, measured between Tick calls (a running mean), and
  // the previous call's time; SetpointLead() from them.
  double streaming_period_ = 0.0;
  double previous_tick_ = -1.0;
  double trim_updated_ = -1.0;
  PlanClock plan_clock_;
  std::optional<Setpoint> last_setpoint_;
  double last_setpoint_time_ = 0.0;
  bool last_setpoint_in_blend_ = false;

  // A moving target: its tracker (null when the goal stands still), the
  // task's target pose (its tool goal at the motion's t = 0), the newest
  // measurement's time, the t = 0 fixed ahead for the plan being made
  // against the prediction (the first, one after a link hold, the
  // insertion from above the target), and the follow's length.
  std::unique_ptr<TargetTracker> tracker_;
  Pose task_target_ = Pose::Identity();
  double target_time_ = -1e300;
  double prediction_zero_ = 0.0;
  std::shared_ptr<const planner::MovingSceneModels> first_target_;
  bool target_wait_noted_ = false;
  double last_target_trigger_ = -1e300;
  // The pending replan starts on the plan itself (a tail: spliced without a
  // blend), and whether from_ (the plan flown now) is kept when it is
  // spliced (it was made while a tail waited for its splice).
  bool pending_exact_ = false, pending_keep_from_ = false;
  double splice_window_ = 0.5;  // s of the blend under way (0: a tail's exact splice)
  double follow_duration_ = 0.0;
  // TargetCorrection's bound for the plan it was last worked out for, and
  // the controller time its ramp began (negative: not yet).
  const planner::PlanResult* correction_plan_ = nullptr;
  double correction_bound_ = 0.0;
  double correction_start_ = -1.0;
  // A moving target approached in two plans (OnlineOptions::target_settle).
  enum class TargetStage { kApproach, kSettling, kInsertion };
  TargetStage target_stage_ = TargetStage::kApproach;
  // A moving target's abort retreats along the plan carried with the target
  // (RetreatReference) and then follows it at the insertion's start for
  // abort_hold; a retreat that the still scene would not leave room for is
  // refused once, and the flight goes on (controller_target.cc).
  bool retreat_follows_target_ = false;
  bool retreat_refused_ = false;
  bool retreat_ended_noted_ = false;
  double retreat_hold_ = 0.0;
  double settle_start_ = 0.0;
  // The settling's longest follow (target_settle_timeout, or less where the
  // follow would come too near the still scene), set as it begins.
  double settle_limit_ = 0.0;
  bool settle_plan_requested_ = false;
  bool SettlesFirst() const {
    return tracker_ != nullptr && options_.target_settle && setup_.task->tool && setup_.task->tool->has_insertion;
  }
  // Plans made now go to the insertion's start.
  bool PlansToPreGrasp() const { return SettlesFirst() && target_stage_ == TargetStage::kApproach; }
  // While settling: whether the vehicle has settled above the target, and
  // the request of the insertion's plan from there.
  void Settle(double t);

  // Perception (PerceptionSetup): the map in its own thread (perception_map.h).
  std::shared_ptr<PerceptionMap> map_;
  std::unique_ptr<perception::FrameGate> gate_;
  bool perception_hold_ = false;  // the brake was for the sensor, not the link
  bool sensor_silent_ = false;
  bool first_local_ = false;      // first_plan_ goes to a local target
  double last_progress_ = 0.0;    // a plan was flown or begun then
  double last_local_request_ = -1e300;
  std::vector<Vec3> blocked_since_asked_;  // new obstacles since the worker's job was asked
  // New obstacles across the plan flown, far enough ahead to replan first:
  // the plan flown then, and when it brakes unless a new plan has replaced
  // it (negative: none).
  const planner::PlanResult* conflicted_plan_ = nullptr;
  double conflict_deadline_ = -1.0;

  OnlineStats stats_;
};


}  // namespace quadhand::online

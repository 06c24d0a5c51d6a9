// The flight record of quadhand-online (--log) and the figures of a flight.
//
// One row per position measurement: the measured vehicle state in the plan
// file's columns (shared/spec/contracts.md: t,px..pz,vx..vz,ax..az,qw..qz,yaw,
// yaw_rate, joints, joint rates; so sim::LoadPlanCsv reads it), then what was
// streamed at that moment: sp_px..sp_pz, sp_vx..sp_vz, sp_ax..sp_az, sp_yaw,
// sp_yaw_rate, sp_<joint>..., sp_<joint>_rate... (empty when nothing was
// streamed), err_pos (|p - sp_p|, m, empty likewise) and phase (PhaseName);
// for a moving target, then target_x..target_z, target_qw..target_qz: the
// pose of the task's tool goal where the controller's tracker had the target
// at the state's time (empty before it had an estimate), as a plan file's
// target columns.
// The measured acceleration is not sent by the vehicle: it is the backward
// difference of the measured velocities (0 in the first row). yaw is the Hopf
// yaw of the measured attitude, yaw_rate the matching rate of the body rates.
// Times are the controller's clock in seconds: a state's time is the time
// the vehicle stamped it (mapped by TIMESYNC), not its arrival.
#pragma once

#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "quadhand/online/controller.h"
#include "quadhand/planner/post_check.h"
#include "quadhand/planner/task.h"
#include "quadhand/robot/robot_model.h"

namespace quadhand::online {

struct FlightSample {
  MeasuredState measured;
  Vec3 acceleration = Vec3::Zero();  // difference of measured velocities
  std::optional<Setpoint> setpoint;  // streamed at the time (none: nothing streamed)
  // What was added to the setpoint's position when it was sent, besides an
  // estimate jump's shift: the tool trim and a moving target's last
  // correction (OnlineController::last_setpoint_shift).
  Vec3 setpoint_shift = Vec3::Zero();
  Phase phase = Phase::kWaitingForVehicle;
  std::optional<Pose> target;        // a moving target's estimated pose (the tool goal's)
};

class FlightLog {
 public:
  // `target_columns`: the CSV has the target's columns (a moving target).
  explicit FlightLog(bool target_columns = false) : target_columns_(target_columns) {}
  // Appends one row (times must increase; a row at the same time replaces the last).
  void Record(const MeasuredState& measured, const std::optional<Setpoint>& setpoint, Phase phase,
              const std::optional<Pose>& target = std::nullopt, const Vec3& setpoint_shift = Vec3::Zero());
  const std::vector<FlightSample>& samples() const { return samples_; }
  std::string Csv(const std::vector<std::string>& joint_names) const;  // CsvHeader + every row
  // The header line, and rows [begin, end) (for a log written as it grows).
  std::string CsvHeader(const std::vector<std::string>& joint_names) const;
  std::string CsvRows(const std::vector<std::string>& joint_names, size_t begin, size_t end) const;

 private:
  bool target_columns_ = false;
  std::vector<FlightSample> samples_;
};

constexpr double kNoEndTime = -1.0;

struct FlightMetrics {
  static constexpr double kNan = std::numeric_limits<double>::quiet_NaN();
  long flying_samples = 0;          // rows in the flying phase
  // |p - sp_p| while flying, m.
  double tracking_mean = kNan, tracking_median = kNan, tracking_p95 = kNan, tracking_max = kNan, tracking_rms = kNan;
  // Smallest exact clearance (link meshes vs the scene points, as the
  // post-check measures it) over the rows from the first flying one on, at
  // the measured attitude and joints; capped at `reach`.
  double min_clearance = kNan;
  double min_clearance_time = kNan;
  std::string closest_link;
  // Tool at the last row vs the task's goal.tool.position (NaN without a
  // tool goal), and the base vs `terminal`.
  double final_tool_error = kNan;
  double final_base_error = kNan;
  // The states the clearance was judged on (from the first flying row on)
  // and the longest time between two of them (s; from the last one to
  // `end_time` too, when given), with the time the gap ended.
  long judged_samples = 0;
  double max_state_gap = 0.0;
  double max_state_gap_time = kNan;
  // A mission's held object (EvaluateMissionFlight): its least clearance
  // less what it had to keep there (negative: it came too close), and that
  // least clearance, its time and its bound; +inf / NaN while nothing was held.
  double held_object_margin = std::numeric_limits<double>::infinity();
  double held_object_min_clearance = kNan;
  double held_object_min_clearance_time = kNan;
  double held_object_bound = kNan;
  // A mission's grasps and releases (not an object held from the start):
  // the step, and the distance of the flown tool from the planned one when
  // the step began (the state nearest that time).
  std::vector<std::pair<size_t, double>> gripper_tool_errors;
};

// The same for a mission (planner::PlanTask's `plan`, flown on `clock`,
// OnlineController::plan_clock()): each state is judged by the leg it falls
// in (by plan time; before the first, the first; after the last, the last)
// - the robot without the object it holds against that phase's scene
// (min_clearance), and the held object alone against the clearance the leg
// gives it less `tolerance`, as the robot is judged at the safety distance
// less it: next to a grasp or release, where the plan keeps the object out
// of its support (>= 0), the flown one may press into it by the tolerance
// (the simulator has no contact; the tool sags by the tracking error while
// it holds). final_base_error is against the plan's last state;
// gripper_tool_errors are filled, each from the state nearest the time the
// plan left the step's start (after a wait at a junction there).
// A flight that failed while flying the plan and held since is judged, from
// the failure on, by the leg it failed in: `frozen_plan_time` (negative: none).
FlightMetrics EvaluateMissionFlight(const std::vector<FlightSample>& samples, const planner::PlanResult& plan,
                                    const PlanClock& clock, const planner::Task& task, double tolerance,
                                    double reach = 0.3, double end_time = kNoEndTime, double frozen_plan_time = -1.0);

// A moving target's points as the flight is judged against them: their
// exact model where the task places them (its motion's t = 0) and the
// task's target pose there (the tool goal's). Each state is judged with them
// moved to where its row's target pose has them; a row without a target
// pose (the tracker had no estimate yet) is judged against them where the
// task places them.
struct MovingJudge {
  const env::ExactMeshModel* exact = nullptr;
  Pose task_target = Pose::Identity();
};

// `moving`: a moving target's points (the final tool error is then against
// the last row's target pose).
FlightMetrics EvaluateFlight(const std::vector<FlightSample>& samples, const robot::RobotModel& robot,
                             const env::ExactMeshModel& exact, const planner::Task& task,
                             const Vec3& terminal_position, double reach = 0.3,
                             double end_time = kNoEndTime, const MovingJudge& moving = {});

}  // namespace quadhand::online

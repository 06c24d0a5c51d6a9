// The verdict on a flown record (quadhand-flightcheck, quadhand-explore's
// own): the exact clearance of the vehicle's own states, row by row, against
// the task's scene. A mission's scene and held object change at the gripper
// events the record reports, with the tool where it was then
// (MissionReplay); a moving target's points are judged where its
// displacement puts them; and the world may change at a time (points that
// appear, judged from then on).
#pragma once

#include <cmath>
#include <limits>
#include <memory>
#include <string>

#include "quadhand/core/status.h"
#include "quadhand/core/types.h"
#include "quadhand/planner/mission_plan.h"
#include "quadhand/planner/planning_context.h"

namespace quadhand::planner {

// One row of a flown record, as the judge needs it.
struct FlownState {
  double t = 0.0;
  Pose base = Pose::Identity();  // world
  VecX joints;
  int gripper = -1;  // 0 open, 1 closed; -1: the record does not say
  // The moving target's displacement from its pose in the task then
  // (identity: nothing moves).
  Pose target = Pose::Identity();
};

class FlightJudge {
 public:
  // `context`: the task's (its exact scene; a mission is replayed). With
  // `after`, rows at or after `after_t` are judged against that context's
  // scene instead (the same task's, with the points that appeared). Both
  // must outlive the judge. Errors name the task and the step.
  static core::Result<std::unique_ptr<FlightJudge>> Create(const PlanningContext& context,
                                                           const MissionPlanOptions& mission,
                                                           const PlanningContext* after = nullptr,
                                                           double after_t = std::numeric_limits<double>::infinity());
  ~FlightJudge();

  // The next row, in time order: a change of the gripper is replayed (an
  // error when it cannot be, such as a close with nothing left to grasp;
  // the caller names the row), and when `judged` its clearances are
  // measured. Rows not judged (outside a window) still change the gripper.
  core::Status Add(const FlownState& row, bool judged = true);

  // Whether the task is a mission (its gripper events are replayed).
  bool replays_mission() const;
  // The least exact clearance of the robot's links over the judged rows,
  // its row's time and its link's name (+infinity before any).
  double least() const { return least_; }
  double least_t() const { return least_t_; }
  const std::string& closest_link() const { return closest_; }
  // The held object's least exact clearance and its time (+infinity when
  // nothing was held at a judged row).
  double least_held() const { return least_held_; }
  double least_held_t() const { return least_held_t_; }
  int gripper_events() const { return gripper_events_; }
  long judged_rows() const { return judged_; }

  class Impl;

 private:
  explicit FlightJudge(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
  double least_ = std::numeric_limits<double>::infinity(), least_t_ = std::nan("");
  std::string closest_;
  double least_held_ = std::numeric_limits<double>::infinity(), least_held_t_ = std::nan("");
  int gripper_events_ = 0;
  long judged_ = 0;
};

}  // namespace quadhand::planner

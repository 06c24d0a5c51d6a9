// The local planner over a recording (docs/perception.md, "Replanning over
// recorded frames"): frames a real or simulated sensor recorded (a frames
// folder, a ROS 1 bag, or frames arriving on UDP, as quadhand-map reads
// them) go into the rolling map as they did in flight, and every
// replan_period seconds of the recording's own time the local planner plans
// from where the recording's vehicle was, to the task's goal.
//
// Open loop: nothing is flown, and the recording goes on where its vehicle
// went, not where the plans would have gone. What it measures is the
// planner on that data: the map update and each plan's latency, which
// plans are certified, and to what.
//
// The vehicle's state at a replan: its base pose is the frame's sensor pose
// times the mount's inverse; its velocity is the base's displacement since
// the frame at least min_velocity_window earlier, divided by the time
// between them (zero before that); its acceleration and yaw rate are zero;
// its joints are the task's start joints. Before the first frame the space
// within start_free_radius of that first base position is taken as free
// (the vehicle stands there, as a flight's take-off).
#pragma once

#include <deque>
#include <optional>
#include <utility>

#include "quadhand/core/types.h"
#include "quadhand/explore/local_planner.h"
#include "quadhand/perception/rolling_map.h"
#include "quadhand/planner/task.h"

namespace quadhand::explore {

struct RecordedReplanOptions {
  double replan_period = 0.5;  // s of the recording's time between replans
  // The sensor's pose in the base link's frame (a fixed mount).
  Pose mount = Pose::Identity();
  double start_free_radius = 0.8;     // m
  double min_velocity_window = 0.05;  // s
  bool IsValid(std::string* why) const;
};

struct RecordedReplan {
  double t = 0.0;                 // the recording's time, s
  planner::BoundaryState start;   // the vehicle's state it planned from
  LocalPlanResult result;
};

class RecordedReplanner {
 public:
  // InvalidArgument for invalid options.
  static core::Result<RecordedReplanner> Create(const LocalPlanner& planner, const planner::Task& task,
                                                const RecordedReplanOptions& options);

  // Before a frame seen from `sensor_to_world` goes into `map`: the first
  // one frees the vehicle's own space and moves the window.
  void BeforeFrame(perception::RollingMap* map, const Pose& sensor_to_world);
  // After it went in: a replan when replan_period has passed since the
  // last (the first at the first frame).
  std::optional<RecordedReplan> AfterFrame(const perception::RollingMap& map, double t, const Pose& sensor_to_world);

 private:
  RecordedReplanner(const LocalPlanner& planner, const planner::Task& task, const RecordedReplanOptions& options)
      : planner_(&planner), task_(&task), options_(options), base_from_sensor_(options.mount.inverse()) {}
  planner::BoundaryState StateAt(double t, const Pose& base) const;
  Pose BaseOf(const Pose& sensor_to_world) const { return sensor_to_world * base_from_sensor_; }

  const LocalPlanner* planner_;
  const planner::Task* task_;
  RecordedReplanOptions options_;
  Pose base_from_sensor_;  // the mount's inverse
  bool started_ = false;
  std::optional<double> last_replan_;
  std::deque<std::pair<double, Vec3>> recent_;  // (t, base position) of the frames of the last window or so
};

}  // namespace quadhand::explore

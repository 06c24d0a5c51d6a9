#include "quadhand/explore/recorded_replans.h"

#include <cmath>
#include <string>

namespace quadhand::explore {
namespace {

bool Fail(std::string* why, const std::string& message) {
  if (why != nullptr) *why = message;
  return false;
}

}  // namespace

bool RecordedReplanOptions::IsValid(std::string* why) const {
  if (!(std::isfinite(replan_period) && replan_period > 0.0 && replan_period <= 3600.0)) {
    return Fail(why, "replan_period must be in (0, 3600] s");
  }
  if (!mount.matrix().allFinite()) return Fail(why, "the mount must be finite");
  if (!(std::isfinite(start_free_radius) && start_free_radius >= 0.0 && start_free_radius <= 10.0)) {
    return Fail(why, "start_free_radius must be in [0, 10] m");
  }
  if (!(std::isfinite(min_velocity_window) && min_velocity_window > 0.0 && min_velocity_window <= 10.0)) {
    return Fail(why, "min_velocity_window must be in (0, 10] s");
  }
  return true;
}

core::Result<RecordedReplanner> RecordedReplanner::Create(const LocalPlanner& planner, const planner::Task& task,
                                                          const RecordedReplanOptions& options) {
  if (std::string why; !options.IsValid(&why)) return core::Status::InvalidArgument("recorded replans: " + why);
  return RecordedReplanner(planner, task, options);
}

void RecordedReplanner::BeforeFrame(perception::RollingMap* map, const Pose& sensor_to_world) {
  if (started_ || map == nullptr) return;
  started_ = true;
  map->MoveWindow(sensor_to_world.translation());
  map->MarkFree(BaseOf(sensor_to_world).translation(), options_.start_free_radius);
}

planner::BoundaryState RecordedReplanner::StateAt(double t, const Pose& base) const {
  planner::BoundaryState state;
  state.position = base.translation();
  // The base's heading: its x axis in the horizontal plane.
  const Vec3 x = base.linear().col(0);
  state.yaw = std::atan2(x.y(), x.x());
  state.velocity = state.acceleration = state.jerk = Vec3::Zero();
  state.yaw_rate = 0.0;
  state.joints = task_->start.joints;
  // The newest earlier frame at least min_velocity_window before t.
  for (auto it = recent_.rbegin(); it != recent_.rend(); ++it) {
    const double dt = t - it->first;
    if (dt >= options_.min_velocity_window) {
      state.velocity = (state.position - it->second) / dt;
      break;
    }
  }
  return state;
}

std::optional<RecordedReplan> RecordedReplanner::AfterFrame(const perception::RollingMap& map, double t,
                                                            const Pose& sensor_to_world) {
  const Pose base = BaseOf(sensor_to_world);
  std::optional<RecordedReplan> replan;
  if (!last_replan_ || t - *last_replan_ >= options_.replan_period - 1e-9) {
    last_replan_ = t;
    RecordedReplan r;
    r.t = t;
    r.start = StateAt(t, base);
    auto planned = planner_->PlanFrom(map, r.start);
    if (planned.ok()) {
      r.result = std::move(*planned);
    } else {
      r.result.status = LocalPlanStatus::kFailed;
      r.result.message = planned.status().message();
    }
    replan = std::move(r);
  }
  recent_.emplace_back(t, base.translation());
  // Only what the next velocity could need: the frames since the newest
  // one at least a window old.
  while (recent_.size() > 2 && t - recent_[1].first >= options_.min_velocity_window) recent_.pop_front();
  return replan;
}

}  // namespace quadhand::explore

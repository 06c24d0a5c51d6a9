// OnlineController flying on a sensor (controller.h, PerceptionSetup;
// docs/perception.md, "Flying online on the sensor"): the frames into the
// rolling map, the plans their new obstacles cross, the sensor's silence,
// the fresh plan after a brake for the sensor, and the points the flight is
// judged against.
#include <algorithm>
#include <chrono>
#include <cmath>

#include "quadhand/core/text.h"
#include "quadhand/online/controller.h"
#include "perception_map.h"

namespace quadhand::online {
namespace {

using core::Format;

bool Fail(std::string* why, const std::string& message) {
  if (why != nullptr) *why = message;
  return false;
}

// s of plan time a brake must stop short of new obstacles ahead for a
// replan to be tried before braking.
constexpr double kConflictSlack = 0.2;

}  // namespace

bool PerceptionSetup::IsValid(std::string* why) const {
  if (std::string map_why; !map.IsValid(&map_why)) return Fail(why, "map: " + map_why);
  if (std::string gate_why; !gate.IsValid(&gate_why)) return Fail(why, "frame gate: " + gate_why);
  auto in = [](double x, double lo, double hi) { return std::isfinite(x) && x > lo && x <= hi; };
  if (!in(sensor_timeout, 0.0, 60.0)) return Fail(why, "sensor_timeout must be in (0, 60] s");
  if (!(std::isfinite(start_free_radius) && start_free_radius >= 0.0 && start_free_radius <= 10.0)) {
    return Fail(why, "start_free_radius must be in [0, 10] m");
  }
  if (min_frames < 1 || min_frames > 1000) return Fail(why, "min_frames must be in [1, 1000]");
  if (!in(replan_period, 0.0, 60.0) || replan_period < 0.01) return Fail(why, "replan_period must be in [0.01, 60] s");
  if (!in(stuck_time, 0.0, 3600.0)) return Fail(why, "stuck_time must be in (0, 3600] s");
  if (!in(seen_period, 0.0, 60.0)) return Fail(why, "seen_period must be in (0, 60] s");
  return true;
}

double OnlineController::PerceptionReplanPeriod() const { return setup_.perception.replan_period; }

double OnlineController::BrakeForSensor(double t) {
  const std::optional<Setpoint> reference = Reference(t);
  const double speed = reference ? reference->velocity.norm() : 0.0;
  BrakeAlongPlan(t, speed);
  perception_hold_ = true;
  ++stats_.perception.sensor_brakes;
  return speed;
}

bool OnlineController::SensorSilent(double t) const {
  // Counted from the vehicle's first hold until the first frame is taken.
  const double last = std::max(gate_->last_taken(), hold_start_);
  return t - last > setup_.perception.sensor_timeout;
}

void OnlineController::OnSensorFrame(double t, perception::SensorFrame frame) {
  if (!perceiving()) return;
  // Judged on the vehicle's stamp on our clock, never later than its arrival.
  frame.t = MeasurementTime(t, frame.t);
  const perception::FrameDrop drop = gate_->Admit(frame, t);
  stats_.perception.frames = gate_->counts();
  if (drop != perception::FrameDrop::kNone) return;
  map_->Push(std::move(frame));
}

void OnlineController::WaitForMap() {
  if (map_) map_->WaitUntilIdle();
}

void OnlineController::CheckNewObstacles(double t, const std::vector<Vec3>& blocked) {
  if (blocked.empty()) return;
  const explore::LocalPlanner& planner = *setup_.perception.planner;
  const double distance = planner.PlannedSafetyDistance(setup_.perception.map.resolution);
  // A plan being made was certified against a map without them.
  if (planning() || replan_pending_ || pending_resume_) {
    blocked_since_asked_.insert(blocked_since_asked_.end(), blocked.begin(), blocked.end());
  }
  PerceptionStats& stats = stats_.perception;
  const bool before_flight = phase_ == Phase::kStreamingHold || phase_ == Phase::kRequestingOffboard ||
                             phase_ == Phase::kArming || phase_ == Phase::kWaitingForPlan;
  if (before_flight && first_plan_ && planner.FirstConflict(*first_plan_->trajectory, 0.0, blocked, distance)) {
    first_plan_.reset();
    first_plan_requested_ = false;
    ++stats.conflicts;
    Event(Format("the first plan crosses %zu voxels a frame found occupied: planning again", blocked.size()));
    return;
  }
  if (phase_ != Phase::kFlying || link_hold_ || retreating_ || !to_.plan) return;
  if (blending_ && t < blend_start_ && from_.plan) {
    // A plan waiting for its splice: from_ is flown until blend_start_, to_ after.
    if (planner.FirstConflict(*to_.plan->trajectory, 0.0, blocked, distance)) {
      to_ = from_;
      from_ = ActivePlan{};
      blending_ = false;
      ++stats.conflicts;
      Event(Format("%zu voxels a frame found occupied cross the plan waiting for its splice: dropped",
                   blocked.size()));
    } else {
      const std::optional<double> before =
          planner.FirstConflict(*from_.plan->trajectory, std::max(0.0, t - from_.start), blocked, distance);
      if (!before || *before >= blend_start_ - from_.start) return;  // not where from_ is flown
      // Within the splice's wait (shorter than a replan's lead): brake.
      const double speed = BrakeForSensor(t);
      ++stats.conflicts;
      ++stats.flown_conflicts;
      Event(Format("%zu voxels a frame found occupied cross the plan flown ", blocked.size()) +
            Format("%.2f s ahead: braking along it from %.2f m/s, then a fresh plan", from_.start + *before - t, speed));
      return;
    }
  }
  const std::optional<double> conflict =
      planner.FirstConflict(*to_.plan->trajectory, std::max(0.0, t - to_.start), blocked, distance);
  if (!conflict) return;
  ++stats.conflicts;
  ++stats.flown_conflicts;
  // Far enough ahead that a brake begun when a replan is due still stops
  // short of it: replan first, brake only if no new plan is flown by then.
  // A replan already asked is checked against these obstacles when it
  // comes (CrossesSeenSinceAsked) and takes that part.
  if (!pending_resume_) {
    const double deadline = conflict_deadline_ >= 0.0 ? conflict_deadline_ : t + options_.replan_lead;
    const double speed_then = SampleActive(to_, deadline).velocity.norm();
    const double stop = deadline - to_.start + 0.5 * BrakeDuration(speed_then);
    if (*conflict > stop + kConflictSlack) {
      if (!replan_pending_ && !planning()) RequestLocalReplan(t, /*exact=*/true, 0.0);
      const bool first = conflict_deadline_ < 0.0;
      conflicted_plan_ = to_.plan.get();
      conflict_deadline_ = deadline;
      if (first) {
        Event(Format("%zu voxels a frame found occupied cross the plan flown ", blocked.size()) +
              Format("%.2f s ahead: replanning (it brakes at t = %.2f s unless a new plan is flown by then)",
                     to_.start + *conflict - t, deadline));
      }
      return;
    }
  }
  const double speed = BrakeForSensor(t);
  Event(Format("%zu voxels a frame found occupied cross the plan flown ", blocked.size()) +
        Format("%.2f s ahead: braking along it from %.2f m/s, then a fresh plan",
               to_.start + *conflict - t, speed));
}

bool OnlineController::CrossesSeenSinceAsked(const planner::PlanResult& plan) const {
  if (blocked_since_asked_.empty() || !plan.trajectory) return false;
  const explore::LocalPlanner& planner = *setup_.perception.planner;
  return planner
      .FirstConflict(*plan.trajectory, 0.0, blocked_since_asked_,
                     planner.PlannedSafetyDistance(setup_.perception.map.resolution))
      .has_value();
}

void OnlineController::CheckSensor(double t) {
  CheckNewObstacles(t, map_->TakeBlocked());
  PerceptionStats& stats = stats_.perception;
  if (conflict_deadline_ >= 0.0) {
    const bool replaced = to_.plan.get() != conflicted_plan_ || link_hold_ || phase_ != Phase::kFlying;
    if (replaced) {
      conflict_deadline_ = -1.0;
    } else if (t >= conflict_deadline_) {
      conflict_deadline_ = -1.0;
      const double speed = BrakeForSensor(t);
      Event(Format("no plan around the new obstacles in time: braking along the plan from %.2f m/s, then a fresh "
                   "plan",
                   speed));
    }
  }
  const PerceptionSetup& perception = setup_.perception;
  const bool silent = SensorSilent(t);
  if (silent && !sensor_silent_) {
    sensor_silent_ = true;
    ++stats.silences;
    if (phase_ == Phase::kFlying && !link_hold_ && !retreating_) {
      const double speed = BrakeForSensor(t);
      Event(Format("no sensor frame taken for %.2f s: braking along the plan from %.2f m/s and holding until frames "
                   "come again",
                   perception.sensor_timeout, speed));
    } else {
      Event(Format("no sensor frame taken for %.2f s: no plan until frames come", perception.sensor_timeout));
    }
  } else if (!silent && sensor_silent_) {
    sensor_silent_ = false;
    last_progress_ = t;
    Event("sensor frames again");
  }
  // Not stuck while the sensor is silent, nor while flying a plan.
  if (silent) last_progress_ = t;
  if (phase_ == Phase::kFlying && !link_hold_ && to_.plan && t - to_.start < to_.plan->trajectory->duration()) {
    last_progress_ = t;
  }

  // After a brake for the sensor: a fresh plan from the measured state at rest.
  if (phase_ == Phase::kFlying && link_hold_ && perception_hold_ && !silent && !pending_resume_ &&
      !replan_pending_ && !planning() && t - link_hold_start_ >= link_brake_duration_ &&
      t - last_local_request_ >= perception.replan_period) {
    RequestFreshLocalPlan(t);
  }

  const bool no_frames_yet = gate_->counts().taken == 0 && have_position_;
  if ((phase_ == Phase::kFlying || phase_ == Phase::kWaitingForPlan) && !finished() &&
      t - last_progress_ > perception.stuck_time) {
    Fail(Phase::kHoldingAfterFailure,
         Format("no plan from what the sensor has seen for %.0f s", perception.stuck_time), HoldCause::kPlanFailed);
  } else if (no_frames_yet && phase_ != Phase::kWaitingForVehicle && phase_ != Phase::kHoldingAfterFailure &&
             !finished() && t - hold_start_ > perception.stuck_time) {
    Fail(Phase::kHoldingAfterFailure, Format("no sensor frame taken in %.0f s", perception.stuck_time),
         HoldCause::kPlanFailed);
  }
}

std::vector<Vec3> OnlineController::SeenPoints() {
  if (!map_) return {};
  map_->WaitUntilIdle();
  std::vector<Vec3> seen = map_->SeenPoints();
  const PerceptionMap::Figures figures = map_->figures();
  PerceptionStats& stats = stats_.perception;
  stats.map_update_ms = figures.update_ms;
  stats.peak_map_bytes = figures.peak_bytes;
  stats.empty_frames = figures.empty_frames;
  stats.map_overrun = figures.overrun;
  stats.seen_points = seen.size();
  return seen;
}

}  // namespace quadhand::online

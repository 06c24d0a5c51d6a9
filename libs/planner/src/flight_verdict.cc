#include "quadhand/planner/flight_verdict.h"

#include <cmath>
#include <vector>

#include "quadhand/planner/moving_scene.h"
#include "quadhand/planner/task.h"
#include "quadhand/robot/kinematics.h"

namespace quadhand::planner {

class FlightJudge::Impl {
 public:
  // The scenes judged against: before the change, and after it (when given).
  std::vector<const PlanningContext*> contexts;
  double after_t = std::numeric_limits<double>::infinity();
  // One replay per scene (a mission), each told of every gripper event.
  std::vector<std::unique_ptr<MissionReplay>> replays;
  int gripper = 0;
  robot::KinematicsState kinematics;

  size_t SceneAt(double t) const { return contexts.size() > 1 && t >= after_t ? 1 : 0; }
};

FlightJudge::FlightJudge(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
FlightJudge::~FlightJudge() = default;

core::Result<std::unique_ptr<FlightJudge>> FlightJudge::Create(const PlanningContext& context,
                                                               const MissionPlanOptions& mission,
                                                               const PlanningContext* after, double after_t) {
  auto impl = std::make_unique<Impl>();
  impl->contexts.push_back(&context);
  if (after != nullptr) {
    impl->contexts.push_back(after);
    impl->after_t = after_t;
  }
  if (!PlansAsGoal(context.task())) {
    for (const PlanningContext* each : impl->contexts) {
      auto started = MissionReplay::Start(*each, mission);
      if (!started.ok()) return started.status();
      impl->replays.push_back(std::move(*started));
    }
    impl->gripper = impl->replays.front()->held_step() >= 0 ? 1 : 0;
  }
  return std::unique_ptr<FlightJudge>(new FlightJudge(std::move(impl)));
}

bool FlightJudge::replays_mission() const { return !impl_->replays.empty(); }

core::Status FlightJudge::Add(const FlownState& row, bool judged) {
  Impl& m = *impl_;
  if (!m.replays.empty() && row.gripper >= 0 && row.gripper != m.gripper) {
    for (const auto& replay : m.replays) {
      QUADHAND_RETURN_IF_ERROR(row.gripper == 1 ? replay->GripperClosed(row.base, row.joints, row.target)
                                                : replay->GripperOpened(row.base, row.joints));
    }
    m.gripper = row.gripper;
    ++gripper_events_;
  }
  if (!judged) return core::Status::Ok();
  ++judged_;
  const size_t scene = m.SceneAt(row.t);
  const PlanningContext& context = *m.contexts[scene];
  int link = -1;
  double d = 0.0;
  if (!m.replays.empty()) {
    const MissionReplay::Clearances c = m.replays[scene]->Measure(row.base, row.joints, 1.0, row.target);
    d = c.robot;
    link = c.robot_link;
    if (c.object < least_held_) {
      least_held_ = c.object;
      least_held_t_ = row.t;
    }
  } else {
    robot::ComputeKinematics(context.robot(), row.base, row.joints, &m.kinematics);
    // A moving target's points, where they are at the row's time.
    const MovingScene* moving = context.moving_scene();
    const bool points_move = moving != nullptr && moving->has_points();
    d = StillAndMovingClearance(m.kinematics, context.exact(), points_move ? moving->exact : nullptr,
                                points_move ? row.target : Pose::Identity(), 1.0, &link);
  }
  if (d < least_) {
    least_ = d;
    least_t_ = row.t;
    closest_ = link >= 0 ? context.robot().link(link).name : "";
  }
  return core::Status::Ok();
}

}  // namespace quadhand::planner

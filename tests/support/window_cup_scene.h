// The default window-and-cup task (data/tasks/window_cup.yaml) as a planning
// scene built in memory: the reference robot with the coarse link SDFs of
// quadhand_fixture.h (no generated files needed), the scene cloud, the exact
// clearance of the post-check and the front-end map. Built once per test binary.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "quadhand/env/mrc_sdf_model.h"
#include "quadhand/planner/front_end.h"
#include "quadhand/planner/planner.h"
#include "quadhand/planner/post_check.h"
#include "quadhand/planner/task.h"
#include "quadhand/scene/point_cloud.h"
#include "support/quadhand_fixture.h"

namespace quadhand::testing {

struct WindowCupScene {
  planner::Task task;
  std::vector<Vec3> points;
  std::unique_ptr<env::MrcSdfModel> model;
  std::unique_ptr<env::ExactMeshModel> exact;
  std::unique_ptr<planner::FrontEndMap> front_end;

  const robot::RobotModel& robot() const { return CoarseQuadHand().robot; }
  planner::PlanningScene Scene() const { return planner::PlanningScene{robot(), *model, *exact, *front_end}; }
};

inline std::string WindowCupTaskPath() { return std::string(QUADHAND_SOURCE_DIR) + "/data/tasks/window_cup.yaml"; }

inline const WindowCupScene& WindowCup() {
  static const WindowCupScene scene = [] {
    const QuadHandFixture& fx = CoarseQuadHand();
    WindowCupScene s;
    s.task = *planner::LoadTask(WindowCupTaskPath());
    const core::Status applied = planner::ApplyRobot(fx.robot, &s.task);
    if (!applied.ok()) std::abort();
    s.points = scene::LoadPcd(s.task.scene_path)->points;
    s.model = std::move(*env::MrcSdfModel::Create(fx.links, fx.grids, s.points));
    s.exact = std::move(*env::ExactMeshModel::Create(fx.robot, s.points));
    std::vector<Vec3> contain = {s.task.start.position, s.task.terminal->position};
    s.front_end = std::make_unique<planner::FrontEndMap>(
        std::move(*planner::FrontEndMap::Build(s.points, planner::FrontEndOptions{}, contain)));
    return s;
  }();
  return scene;
}

}  // namespace quadhand::testing

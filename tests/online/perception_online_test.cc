// The online controller flying on a sensor (controller.h, PerceptionSetup):
// in-process against the simulator, a depth camera on the vehicle rendering
// a hidden row of posts, the controller given only its frames. It arrives
// with its clearance against the true world; a silent sensor brakes and
// holds it; an obstacle appearing across the plan flown brakes it and a
// fresh plan goes around; a plan to a local target ending is not an arrival.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>

#include "online_test_util.h"
#include "quadhand/explore/local_planner.h"
#include "quadhand/planner/planner_config.h"
#include "quadhand/planner/planning_context.h"
#include "quadhand/robot/kinematics.h"
#include "quadhand/sim/sensor.h"
#include "support/posts_world.h"
#include "support/window_cup_task.h"

namespace quadhand::online::testing {
namespace {

// The posts on a floor (support/posts_world.h).
std::vector<Vec3> Posts() { return quadhand::testing::PostsWorld(/*with_floor=*/true); }

// A task from (0, 0, 1.2) to (8, 0, 1.2) at rest, the arm stowed; its scene
// is only the judge's.
planner::Task PostsTask() {
  planner::Task task = WindowCup().task;
  task.tool.reset();
  task.sdf_dir = quadhand::testing::CoarseSdfDir();  // a clean clone has no generated SDFs
  task.start = planner::BoundaryState{};
  task.start.position = Vec3(0.0, 0.0, 1.2);
  task.start.joints = Eigen::Vector3d(0.3, -0.2, 0.0);
  planner::BoundaryState goal = task.start;
  goal.position = Vec3(8.0, 0.0, 1.2);
  task.terminal = goal;
  task.limits.v_max = 2.0;
  task.limits.a_max = 4.0;
  task.safety_distance = 0.03;
  return task;
}

class PerceptionOnlineTest : public ::testing::Test {
 protected:
  void SetUp() override {
    task_ = PostsTask();
    config_ = planner::DefaultPlannerConfig();
    explore::UseLocalPlanningDefaults(&config_);
    auto base = explore::BaseContext(task_, WindowCup().robot(), config_);
    ASSERT_TRUE(base.ok()) << base.status().message();
    base_ = std::move(*base);
    options_ = planner::RunPlannerOptions(config_, 0.01, 1, false);
    options_.solver.max_time_seconds = 60.0;  // iterations only: deterministic under load
    auto local = explore::LocalPlanner::Create(*base_, options_, Solver(), explore::LocalPlannerOptions{});
    ASSERT_TRUE(local.ok()) << local.status().message();
    local_ = std::move(*local);
    sensor_ = SimConfig().sensor;
  }

  std::unique_ptr<OnlineController> Controller(const OnlineOptions& options = {},
                                               const perception::RollingMapOptions& map = {}) {
    PlanningSetup setup{base_->Scene(), &base_->task(), options_, planner::DefaultReplanOptions(), &Solver()};
    setup.perception.planner = local_.get();
    setup.perception.map = map;
    auto controller = OnlineController::Create(setup, options);
    EXPECT_TRUE(controller.ok()) << controller.status().message();
    return controller.ok() ? std::move(*controller) : nullptr;
  }

  // Renders `world` from the sensor on the simulated vehicle every other
  // 50 Hz period (25 Hz), except in [silent_from, silent_to), and hands
  // each frame to the controller as it arrives.
  std::function<void(double, sim::Simulator*)> Camera(OnlineController* controller, sim::SensorRenderer* renderer,
                                                       sim::SensorRenderer* later = nullptr, double later_from = 1e9,
                                                       double silent_from = 1e9, double silent_to = 1e9) {
    const robot::RobotModel& robot = WindowCup().robot();
    const int link = robot.LinkIndex(sensor_.link);
    EXPECT_GE(link, 0);
    auto period = std::make_shared<long>(0);
    return [=](double t, sim::Simulator* sim) {
      if ((*period)++ % 2 != 0 || (t >= silent_from && t < silent_to)) return;
      const sim::VehicleState& s = sim->state();
      const Pose base = MakePose(s.position, s.attitude.toRotationMatrix());
      const Pose pose = robot::LinkPose(robot, base, s.joints, link) * sensor_.Mount();
      sim::SensorRenderer* now = t >= later_from ? later : renderer;
      perception::SensorFrame frame;
      frame.t = t;
      perception::SetSensorPose(pose, &frame);
      frame.points = now->Render(pose);
      frame.misses = now->LastMisses(8);
      controller->OnSensorFrame(t, std::move(frame));
      controller->WaitForMap();
    };
  }

  // The flight's least clearance against `world` (the vehicle's own states).
  FlightMetrics Judge(const DirectFlight& flight, const OnlineController& controller, const std::vector<Vec3>& world) {
    auto judge = planner::PlanningContext::Create(task_, WindowCup().robot(),
                                                  std::make_shared<const std::vector<Vec3>>(world), 0,
                                                  planner::ContextOptions(config_, {}));
    EXPECT_TRUE(judge.ok());
    return EvaluateFlight(flight.log().samples(), WindowCup().robot(), (*judge)->exact(), task_,
                          controller.current_plan()->terminal.position);
  }

  std::unique_ptr<sim::SensorRenderer> Renderer(const std::vector<Vec3>& world) {
    auto renderer = sim::SensorRenderer::Create(world, sensor_, 5);
    EXPECT_TRUE(renderer.ok());
    return std::move(*renderer);
  }

  planner::Task task_;
  planner::PlannerConfig config_;
  planner::PlannerOptions options_;
  std::unique_ptr<planner::PlanningContext> base_;
  std::unique_ptr<explore::LocalPlanner> local_;
  sim::SensorConfig sensor_;
};

TEST_F(PerceptionOnlineTest, FliesPastPostsItHasNeverSeenOnItsFramesAlone) {
  auto controller = Controller();
  ASSERT_NE(controller, nullptr);
  auto renderer = Renderer(Posts());
  DirectFlight flight(controller.get(), {}, &task_);
  flight.Run(60.0, Camera(controller.get(), renderer.get()));
  ASSERT_EQ(controller->phase(), Phase::kArrived) << flight.Events();
  EXPECT_TRUE(controller->finished());
  const OnlineStats& stats = controller->stats();
  // The goal was behind the first post: local targets first, then the goal.
  ASSERT_FALSE(stats.plans.empty());
  EXPECT_EQ(stats.plans.front().local_status, static_cast<int>(explore::LocalPlanStatus::kToLocalTarget));
  int to_goal = 0;
  for (const PlanRecord& r : stats.plans) {
    EXPECT_GE(r.local_status, 0);  // every plan a local one
    to_goal += r.local_status == static_cast<int>(explore::LocalPlanStatus::kToGoal);
  }
  EXPECT_GE(to_goal, 1);
  EXPECT_GT(stats.splices, 2);
  EXPECT_GT(stats.perception.frames.taken, 100);
  const FlightMetrics truth = Judge(flight, *controller, Posts());
  EXPECT_GE(truth.min_clearance, 0.028) << flight.Events();
  EXPECT_LT(truth.final_base_error, 0.05);
  // What the sensor saw: the posts, not more (every seen point near one;
  // the depth noise is 0.002 m times the depth squared, 7 cm at 6 m).
  const std::vector<Vec3> seen = controller->SeenPoints();
  ASSERT_GT(seen.size(), 1000u);
  for (size_t i = 0; i < seen.size(); i += 97) {
    double nearest = std::abs(seen[i].z());  // the floor
    for (const Vec3& c : quadhand::testing::PostCentres()) {
      nearest = std::min(nearest, std::abs((seen[i] - c).head<2>().norm() - 0.15));
    }
    EXPECT_LT(nearest, 0.3) << seen[i].transpose();
  }
}

TEST_F(PerceptionOnlineTest, ASilentSensorBrakesAndHoldsUntilFramesReturn) {
  auto controller = Controller();
  ASSERT_NE(controller, nullptr);
  auto renderer = Renderer(Posts());
  DirectFlight flight(controller.get(), {}, &task_);
  // Silent from 4.5 s (in flight: the handshake and first plan take ~2.5 s) to 7 s.
  flight.Run(60.0, Camera(controller.get(), renderer.get(), nullptr, 1e9, 4.5, 7.0));
  ASSERT_EQ(controller->phase(), Phase::kArrived) << flight.Events();
  const PerceptionStats& p = controller->stats().perception;
  EXPECT_GE(p.silences, 1);
  EXPECT_GE(p.sensor_brakes, 1) << flight.Events();
  // Held: from the brake's end plus half a second until frames return.
  int held = 0;
  double fastest_before = 0.0;
  for (const FlightSample& s : flight.log().samples()) {
    const double t = s.measured.time;
    if (t > 3.5 && t < 4.5) fastest_before = std::max(fastest_before, s.measured.velocity.norm());
    if (t < 4.5 + 0.3 + 1.5 || t > 7.0) continue;
    EXPECT_LT(s.measured.velocity.norm(), 0.1) << "t " << t << "\n" << flight.Events();
    ++held;
  }
  EXPECT_GT(fastest_before, 0.3);  // it was flying when the sensor fell silent
  EXPECT_GT(held, 20);
  EXPECT_GE(Judge(flight, *controller, Posts()).min_clearance, 0.028);
}

TEST_F(PerceptionOnlineTest, AnObstacleAppearingAcrossThePlanBrakesItAndAFreshPlanGoesAround) {
  OnlineOptions options;
  auto controller = Controller(options);
  ASSERT_NE(controller, nullptr);
  std::vector<Vec3> patch;
  // A 2 x 1.8 m patch across the way, 1 m ahead of the vehicle when it appears.
  for (double y = -1.0; y <= 1.0 + 1e-9; y += 0.04) {
    for (double z = 0.3; z <= 2.1 + 1e-9; z += 0.04) patch.emplace_back(2.2, y, z);
  }
  std::vector<Vec3> with_patch = Posts();
  with_patch.insert(with_patch.end(), patch.begin(), patch.end());
  auto renderer = Renderer(Posts());
  auto later = Renderer(with_patch);
  DirectFlight flight(controller.get(), {}, &task_);
  // It appears once the vehicle flies towards it (its first plan runs ~3 s).
  flight.Run(60.0, Camera(controller.get(), renderer.get(), later.get(), 3.4));
  const PerceptionStats& p = controller->stats().perception;
  EXPECT_GE(p.flown_conflicts, 1) << flight.Events();
  ASSERT_EQ(controller->phase(), Phase::kArrived) << flight.Events();
  EXPECT_GE(Judge(flight, *controller, with_patch).min_clearance, 0.028) << flight.Events();
}

// The flight is judged against the map's last word on each voxel. By
// default a voxel a return ended in stays occupied
// (RollingMapOptions::returns_stay_occupied), so a blob seen and then seen
// through stays among the points judged against; under OctoMap's model
// alone the rays through it free it, and its returns (a far, noisy view)
// are not judged against.
TEST_F(PerceptionOnlineTest, WhatWasSeenIsTheMapsLastWordOnEachVoxel) {
  for (bool sticky : {true, false}) {
    SCOPED_TRACE(sticky ? "returns stay occupied" : "OctoMap's model alone");
    perception::RollingMapOptions map;
    map.returns_stay_occupied = sticky;
    auto controller = Controller({}, map);
    ASSERT_NE(controller, nullptr);
    std::vector<Vec3> wall;  // 3 m ahead along the sensor's z
    for (double x = -1.0; x <= 1.0 + 1e-9; x += 0.02) {
      for (double y = -1.0; y <= 1.0 + 1e-9; y += 0.02) wall.emplace_back(x, y, 3.0);
    }
    const Vec3 blob(0.02, 0.03, 1.53);  // in front of it
    double t = 0.0;
    auto frame = [&](bool with_blob) {
      t += 0.04;
      perception::SensorFrame f;
      f.t = t;
      perception::SetSensorPose(Pose::Identity(), &f);
      f.points = wall;
      if (with_blob) f.points.insert(f.points.end(), 20, blob);
      controller->OnSensorFrame(t, std::move(f));
      controller->WaitForMap();
    };
    auto near_blob = [&](const std::vector<Vec3>& points) {
      size_t n = 0;
      for (const Vec3& p : points) n += (p - blob).norm() < 0.05;
      return n;
    };
    for (int k = 0; k < 5; ++k) frame(true);
    const std::vector<Vec3> before = controller->SeenPoints();
    EXPECT_GT(near_blob(before), 0u);  // seen occupied
    for (int k = 0; k < 30; ++k) frame(false);
    const std::vector<Vec3> after = controller->SeenPoints();
    if (sticky) {
      EXPECT_GT(near_blob(after), 0u);  // a return's voxel stays occupied
    } else {
      EXPECT_EQ(near_blob(after), 0u);  // since seen through: free
    }
    size_t on_wall = 0;
    for (const Vec3& p : after) on_wall += std::abs(p.z() - 3.0) < 1e-9;
    EXPECT_GT(on_wall, 1000u);
  }
}

TEST_F(PerceptionOnlineTest, RefusesAToolGoalAndBadOptions) {
  PlanningSetup setup{base_->Scene(), &WindowCup().task, options_, planner::DefaultReplanOptions(), &Solver()};
  setup.perception.planner = local_.get();
  EXPECT_FALSE(OnlineController::Create(setup, {}).ok());  // the default task's goal is a tool pose
  setup.task = &base_->task();
  setup.perception.sensor_timeout = 0.0;
  EXPECT_FALSE(OnlineController::Create(setup, {}).ok());
  setup.perception.sensor_timeout = 0.3;
  setup.perception.seen_period = std::nan("");
  EXPECT_FALSE(OnlineController::Create(setup, {}).ok());
}

}  // namespace
}  // namespace quadhand::online::testing

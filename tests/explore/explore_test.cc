// Flying on the sensor (explore/local_planner.h, exploration_flight.h,
// quadhand-explore): a local plan certified against what the map has not
// seen free (to a local target before a wall it cannot see behind, to the
// goal once it is seen free, nothing when nothing is seen), and a whole
// lockstep flight through an unseen row of posts judged against the true
// world; the same with a silent sensor and bad frames, and with an obstacle
// that appears across the plan; quadhand-explore's bad input.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>

#include <nlohmann/json.hpp>

#include "quadhand/core/text.h"
#include "quadhand/explore/grasp_under_perception.h"
#include "quadhand/explore/guide.h"
#include "quadhand/explore/local_planner.h"
#include "quadhand/explore/look_round.h"
#include "quadhand/explore/recorded_replans.h"
#include "quadhand/explore/sensor_faults.h"
#include "quadhand/opt/solver_registry.h"
#include "quadhand/perception/rolling_map.h"
#include "quadhand/planner/planner_config.h"
#include "quadhand/planner/moving_scene.h"
#include "quadhand/planner/planning_context.h"
#include "quadhand/robot/kinematics.h"
#include "quadhand/sim/plan_io.h"
#include "quadhand/sim/sensor.h"
#include "quadhand/scene/point_cloud.h"
#include "quadhand/solvers/builtin_solvers.h"
#include "support/posts_world.h"
#include "support/run_command.h"
#include "support/window_cup_task.h"

namespace quadhand {
namespace {

namespace fs = std::filesystem;
using testing::RunCommand;

const std::string kExplore = std::string(QUADHAND_BIN_DIR) + "/quadhand-explore";

// A wall in the plane x = `x` (|y| <= 3, 0 <= z <= 3), every 2 cm.
std::vector<Vec3> WallAt(double x) {
  std::vector<Vec3> points;
  for (double y = -3.0; y <= 3.0 + 1e-9; y += 0.02) {
    for (double z = 0.0; z <= 3.0 + 1e-9; z += 0.02) points.emplace_back(x, y, z);
  }
  return points;
}

class ExploreTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("quadhand_explore_" + std::to_string(getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    flown_ = (dir_ / "flown.csv").string();
    report_ = (dir_ / "report.json").string();
  }
  void TearDown() override { fs::remove_all(dir_); }

  // A task from (0, 0, 1.2) to `goal` at rest, the arm stowed, on `world`.
  std::string WriteTask(const std::vector<Vec3>& world, const Vec3& goal, const std::string& name = "task") {
    const std::string cloud = (dir_ / (name + ".pcd")).string();
    EXPECT_TRUE(scene::WritePcd(cloud, world).ok());
    const std::string path = (dir_ / (name + ".yaml")).string();
    std::ofstream(path) << "robot: " << QUADHAND_SOURCE_DIR << "/meshes/quadhand/quadhand.urdf\n"
                        << "sdf_dir: " << testing::CoarseSdfDir() << "\n"
                        << "scene: " << cloud << "\n"
                        << "start: {position: [0.0, 0.0, 1.2], yaw: 0.0, joints: [0.3, -0.2, 0.0]}\n"
                        << core::Format("goal: {position: [%g, %g, %g], yaw: 0.0, joints: [0.3, -0.2, 0.0]}\n",
                                        goal.x(), goal.y(), goal.z())
                        << "limits: {v_max: 2.0, a_max: 4.0, yaw_rate_max: 1.5, body_rate_xy_max: 3.0}\n"
                        << "safety_distance: 0.03\n";
    return path;
  }

  struct Planner {
    std::unique_ptr<planner::PlanningContext> base;
    std::unique_ptr<opt::Solver> solver;
    std::unique_ptr<explore::LocalPlanner> local;
  };
  // The local planner of a task (its scene unused: a point far above).
  Planner MakePlanner(const std::string& task_path) {
    Planner p;
    auto task = planner::LoadTask(task_path);
    EXPECT_TRUE(task.ok()) << task.status().message();
    auto robot = robot::RobotModel::LoadFromUrdfFile(task->robot_path);
    EXPECT_TRUE(robot.ok());
    const planner::PlannerConfig config = planner::DefaultPlannerConfig();
    auto base = explore::BaseContext(*task, *robot, config);
    EXPECT_TRUE(base.ok()) << base.status().message();
    p.base = std::move(*base);
    EXPECT_TRUE(solvers::RegisterBuiltinSolvers().ok());
    auto solver = opt::CreateSolver("lbfgs");
    EXPECT_TRUE(solver.ok());
    p.solver = std::move(*solver);
    auto local = explore::LocalPlanner::Create(*p.base, planner::RunPlannerOptions(config, 0.01, 1, false), *p.solver,
                                               explore::LocalPlannerOptions{});
    EXPECT_TRUE(local.ok()) << local.status().message();
    p.local = std::move(*local);
    return p;
  }

  // The gap-crossing grasp's cup (70/80 mm, 0.10 m, its walls every 5 mm)
  // on its 0.5 m cube about (-2.2, 0, 0.25), on a floor, and nothing else.
  static std::vector<Vec3> CupOnCubeWorld() {
    std::vector<Vec3> world;
    for (double x = -3.0; x <= 0.5 + 1e-9; x += 0.02) {
      for (double y = -1.5; y <= 1.5 + 1e-9; y += 0.02) world.emplace_back(x, y, 0.0);
    }
    for (double u = -0.25; u <= 0.25 + 1e-9; u += 0.01) {
      for (double v = -0.25; v <= 0.25 + 1e-9; v += 0.01) {
        for (double side : {-0.25, 0.25}) {
          world.emplace_back(-2.2 + side, u, 0.25 + v);
          world.emplace_back(-2.2 + u, side, 0.25 + v);
          world.emplace_back(-2.2 + u, v, 0.25 + side);
        }
      }
    }
    for (double z = 0.5; z <= 0.6 + 1e-9; z += 0.005) {
      for (const double radius : {0.04, 0.035}) {
        const int around = static_cast<int>(std::round(2.0 * M_PI * radius / 0.005));
        for (int k = 0; k < around; ++k) {
          const double a = 2.0 * M_PI * k / around;
          world.emplace_back(-2.2 + radius * std::cos(a), radius * std::sin(a), z);
        }
      }
    }
    for (int k = 0; k < 50; ++k) {
      const double a = 2.0 * M_PI * k / 50.0;
      world.emplace_back(-2.2 + 0.0375 * std::cos(a), 0.0375 * std::sin(a), 0.6);
    }
    return world;
  }
  // The bundled gap-crossing grasp on `world` (written as `name`.pcd), its
  // start's lines replaced by `start` (each "key: value" at the start's
  // indentation).
  std::string WriteGraspTask(const std::vector<Vec3>& world, const std::string& name,
                             const std::vector<std::string>& start) {
    const std::string cloud = (dir_ / (name + ".pcd")).string();
    EXPECT_TRUE(scene::WritePcd(cloud, world).ok());
    std::string text = testing::ReadAll(std::string(QUADHAND_SOURCE_DIR) + "/data/tasks/missions/gap_crossing_grasp.yaml");
    auto replace_line = [&](const std::string& key, const std::string& line) {
      const size_t at = text.find("\n" + key);
      ASSERT_NE(at, std::string::npos) << key;
      text.replace(at + 1, text.find('\n', at + 1) - at - 1, line);
    };
    replace_line("robot:", std::string("robot: ") + QUADHAND_SOURCE_DIR + "/meshes/quadhand/quadhand.urdf");
    replace_line("sdf_dir:", "sdf_dir: " + testing::CoarseSdfDir());
    replace_line("scene:", "scene: " + cloud);
    for (const std::string& line : start) replace_line("  " + line.substr(0, line.find(':') + 1), "  " + line);
    const std::string path = (dir_ / (name + ".yaml")).string();
    std::ofstream(path) << text;
    return path;
  }
  // The bundled simulator's configuration with these sensor lines replaced
  // (each "key: value", at the sensor's indentation; a commented key too).
  std::string WriteSimConfig(const std::vector<std::string>& sensor_lines) {
    std::string sim = testing::ReadAll(std::string(QUADHAND_SOURCE_DIR) + "/data/sim/quadhand_sim.yaml");
    for (const std::string& line : sensor_lines) {
      const std::string key = line.substr(0, line.find(':') + 1);
      size_t at = sim.find("\n  " + key);
      if (at == std::string::npos) at = sim.find("\n  # " + key);
      EXPECT_NE(at, std::string::npos) << key;
      if (at == std::string::npos) continue;
      sim.replace(at + 1, sim.find('\n', at + 1) - at - 1, "  " + line);
    }
    const std::string path = (dir_ / "sim.yaml").string();
    std::ofstream(path) << sim;
    return path;
  }

  // quadhand-explore flies `task` (`args` added, --quiet): its flown record
  // into flown_, its report into report_, both in the test's folder.
  testing::CommandResult Explore(const std::string& task, const std::string& args = "") const {
    return RunCommand(kExplore + " " + task + " --out " + flown_ + " --report " + report_ + " " + args + " --quiet");
  }
  nlohmann::json Report() const { return nlohmann::json::parse(testing::ReadAll(report_)); }
  // quadhand-flightcheck's independent verdict on the flown record against
  // `task`'s scene.
  testing::CommandResult Flightcheck(const std::string& task) const {
    return RunCommand(std::string(QUADHAND_BIN_DIR) + "/quadhand-flightcheck " + task + " " + flown_);
  }

  // A pocket open towards the start, its end wall across the way to a goal
  // 8 m off (walls 3 m tall on a floor), written as a task that starts 1 m
  // before the pocket's mouth.
  std::string WritePocketTask() {
    std::vector<Vec3> world;
    for (double y = -2.0; y <= 2.0 + 1e-9; y += 0.04) {
      for (double z = 0.0; z <= 3.0 + 1e-9; z += 0.04) world.emplace_back(3.0, y, z);
    }
    for (double side : {-2.0, 2.0}) {
      for (double x = 0.0; x <= 3.0 + 1e-9; x += 0.04) {
        for (double z = 0.0; z <= 3.0 + 1e-9; z += 0.04) world.emplace_back(x, side, z);
      }
    }
    for (double x = -3.0; x <= 10.0 + 1e-9; x += 0.05) {
      for (double y = -6.0; y <= 6.0 + 1e-9; y += 0.05) world.emplace_back(x, y, 0.0);
    }
    const std::string task = WriteTask(world, Vec3(7.0, 0.0, 1.2));
    std::string text = testing::ReadAll(task);
    const std::string from = "position: [0.0, 0.0, 1.2]", to = "position: [-1.0, 0.0, 1.2]";
    text.replace(text.find(from), from.size(), to);
    std::ofstream(task) << text;
    return task;
  }

  fs::path dir_;
  std::string flown_, report_;
};

std::unique_ptr<perception::RollingMap> MapOf(const std::vector<Vec3>& seen, const Vec3& origin) {
  auto map = perception::RollingMap::Create(perception::RollingMapOptions{});
  EXPECT_TRUE(map.ok());
  (*map)->MoveWindow(origin);
  (*map)->MarkFree(origin, 0.8);  // the vehicle and its arm, with the margins
  EXPECT_TRUE((*map)->Insert(seen, origin).ok());
  return std::move(*map);
}

// Every sample of the plan: the base in a free voxel, and the robot clear of
// the boundary (the post-check certified it; here only the base's centre is
// re-read, against the map itself).
void ExpectInSeenFreeSpace(const planner::WholeBodyTrajectory& trajectory, const perception::RollingMap& map) {
  for (double t = 0.0; t <= trajectory.duration(); t += 0.02) {
    const Vec3 p = trajectory.Sample(t).position;
    ASSERT_EQ(map.State(p), perception::VoxelState::kFree) << "t " << t << ": " << p.transpose();
  }
}

TEST_F(ExploreTest, PlansToALocalTargetBeforeAWallItCannotSeeBehind) {
  const std::vector<Vec3> wall = WallAt(4.0);
  Planner p = MakePlanner(WriteTask(wall, Vec3(8.0, 0.0, 1.2)));
  const Vec3 start(0.0, 0.0, 1.2);
  auto map = MapOf(wall, start);
  planner::BoundaryState from = p.base->task().start;
  auto planned = p.local->PlanFrom(*map, from);
  ASSERT_TRUE(planned.ok()) << planned.status().message();
  ASSERT_EQ(planned->status, explore::LocalPlanStatus::kToLocalTarget) << planned->message;
  ASSERT_TRUE(planned->plan.success && planned->plan.trajectory);
  // Before the wall, nearer the goal than the start, and where the plan ends.
  EXPECT_LT(planned->target.x(), 4.0);
  EXPECT_LT((planned->target - Vec3(8.0, 0.0, 1.2)).norm(), 8.0 - 0.3);
  const planner::WholeBodyTrajectory& trajectory = *planned->plan.trajectory;
  EXPECT_LT((trajectory.Sample(trajectory.duration()).position - planned->target).norm(), 1e-6);
  EXPECT_LT(trajectory.Sample(trajectory.duration()).velocity.norm(), 1e-6);  // ends at rest
  ExpectInSeenFreeSpace(trajectory, *map);
  EXPECT_GT(planned->scene_points, 1000u);
  // Planned at the safety distance plus the tracking margin plus half a
  // voxel's diagonal.
  const double planned_distance = p.local->PlannedSafetyDistance(map->options().resolution);
  EXPECT_NEAR(planned_distance, 0.03 + 0.03 + 0.05 * std::sqrt(3.0), 1e-12);
  EXPECT_GE(planned->plan.post_check.min_clearance_exact, planned_distance - 1e-3);
}

TEST_F(ExploreTest, PlansToTheGoalOnceItIsSeenFree) {
  const std::vector<Vec3> wall = WallAt(5.0);
  const Vec3 goal(2.5, 0.3, 1.2);
  Planner p = MakePlanner(WriteTask(wall, goal));
  auto map = MapOf(wall, Vec3(0.0, 0.0, 1.2));
  auto planned = p.local->PlanFrom(*map, p.base->task().start);
  ASSERT_TRUE(planned.ok());
  ASSERT_EQ(planned->status, explore::LocalPlanStatus::kToGoal) << planned->message;
  const planner::WholeBodyTrajectory& trajectory = *planned->plan.trajectory;
  EXPECT_LT((trajectory.Sample(trajectory.duration()).position - goal).norm(), 1e-6);
  ExpectInSeenFreeSpace(trajectory, *map);

  // FirstConflict against points at known distances from the base's frame
  // origin on the plan (the base link's mesh lies within 0.5 m of it): a
  // point where the base will be conflicts by then; one 3 m above the path
  // never does; one the plan has passed, looked for from later, neither.
  const double half = 0.5 * trajectory.duration();
  const Vec3 there = trajectory.Sample(half).position;
  const auto conflict = p.local->FirstConflict(trajectory, 0.0, {there}, 0.1);
  ASSERT_TRUE(conflict.has_value());
  EXPECT_LE(*conflict, half + 1e-9);
  EXPECT_GT(*conflict, 0.0);
  // Exact: no sample before the conflict comes within the distance.
  const auto nearer = p.local->FirstConflict(trajectory, 0.0, {there}, 1e-3);
  ASSERT_TRUE(nearer.has_value());
  EXPECT_GE(*nearer, *conflict);
  EXPECT_FALSE(p.local->FirstConflict(trajectory, 0.0, {there + Vec3(0.0, 0.0, 3.0)}, 0.1).has_value());
  EXPECT_FALSE(p.local->FirstConflict(trajectory, 0.0, {}, 0.1).has_value());
  const Vec3 start_point = trajectory.Sample(0.0).position;
  EXPECT_TRUE(p.local->FirstConflict(trajectory, 0.0, {start_point}, 0.1).has_value());
  if ((trajectory.Sample(trajectory.duration()).position - start_point).norm() > 2.0) {
    EXPECT_FALSE(p.local->FirstConflict(trajectory, trajectory.duration(), {start_point}, 0.1).has_value());
  }
}

// A start nearer the map's boundary than the certificate's floor (the task's
// distance plus the ball radius), as a brake that could not stop short of a
// new obstacle leaves the vehicle: the plan backs away, never nearer than it
// started, and holds the planned distance from recovery_time on. Without the
// recovery rule no plan could be certified from there.
TEST_F(ExploreTest, AStartInsideTheCertificatesFloorBacksAway) {
  const std::vector<Vec3> wall = WallAt(1.6);
  Planner p = MakePlanner(WriteTask(wall, Vec3(8.0, 0.0, 1.2)));
  auto map = MapOf(wall, Vec3(0.0, 0.0, 1.2));
  const double floor = 0.03 + map->BoundaryBallRadius();
  const double planned_distance = p.local->PlannedSafetyDistance(map->options().resolution);
  // Nearer the wall step by step until the start is inside the floor (its
  // clearance as the local plan measures it) but clear of the centres.
  std::optional<explore::LocalPlanResult> inside;
  planner::BoundaryState from = p.base->task().start;
  for (double x = 0.6; x < 1.6 && !inside; x += 0.01) {
    from.position.x() = x;
    if (map->State(from.position) != perception::VoxelState::kFree) break;
    auto planned = p.local->PlanFrom(*map, from);
    ASSERT_TRUE(planned.ok()) << planned.status().message();
    if (planned->start_clearance < floor - 0.02 && planned->start_clearance > 0.01) inside = std::move(*planned);
  }
  ASSERT_TRUE(inside.has_value()) << "no start found inside the floor";
  EXPECT_TRUE(inside->recovery);
  ASSERT_TRUE(inside->status == explore::LocalPlanStatus::kToLocalTarget ||
              inside->status == explore::LocalPlanStatus::kToGoal)
      << inside->message;
  const planner::PostCheckReport& check = inside->plan.post_check;
  EXPECT_TRUE(check.passed && check.certified && check.recovery) << check.FirstFailure();
  EXPECT_GE(check.certified_clearance, inside->start_clearance - 0.002 - 1e-9);
  // From recovery_time on, the planned distance (the last sample's too).
  const planner::WholeBodyTrajectory& trajectory = *inside->plan.trajectory;
  const double recovery_time = p.local->options().recovery_time;
  for (const planner::CertifiedInterval& stretch : check.certified_intervals) {
    if (stretch.t0 >= recovery_time) {
      EXPECT_GE(stretch.clearance_lower, planned_distance - 0.002) << stretch.t0;
    }
  }
  EXPECT_GT(trajectory.duration(), recovery_time);
  EXPECT_GE((trajectory.Sample(trajectory.duration()).position - from.position).norm(), 0.3);  // min_progress
  EXPECT_GE(check.certified_intervals.back().clearance_at_t1, planned_distance - 0.002);
  ExpectInSeenFreeSpace(trajectory, *map);
}

TEST_F(ExploreTest, NothingSeenGivesNoPlan) {
  Planner p = MakePlanner(WriteTask(WallAt(5.0), Vec3(8.0, 0.0, 1.2)));
  auto map = MapOf({}, Vec3(0.0, 0.0, 1.2));  // only the vehicle's own space
  auto planned = p.local->PlanFrom(*map, p.base->task().start);
  ASSERT_TRUE(planned.ok());
  EXPECT_TRUE(planned->status == explore::LocalPlanStatus::kNoTarget ||
              planned->status == explore::LocalPlanStatus::kFailed)
      << explore::LocalPlanStatusName(planned->status);
  EXPECT_FALSE(planned->plan.trajectory.has_value());
  // A start of the wrong size is an error, not a status.
  planner::BoundaryState bad = p.base->task().start;
  bad.joints.resize(1);
  EXPECT_FALSE(p.local->PlanFrom(*map, bad).ok());
}

// A turn in place (LocalPlanner::PlanTurnFrom) from rest in the vehicle's
// own seen-free ball: certified, the base held within centimetres of where
// it stands, the sensor's heading brought to the one asked; a non-finite
// heading is an error.
TEST_F(ExploreTest, TurnsInPlaceWithinWhatItHasSeenFree) {
  Planner p = MakePlanner(WriteTask(WallAt(5.0), Vec3(8.0, 0.0, 1.2)));
  auto map = MapOf({}, Vec3(0.0, 0.0, 1.2));
  const planner::BoundaryState& from = p.base->task().start;
  auto turned = p.local->PlanTurnFrom(*map, from, 2.0);
  ASSERT_TRUE(turned.ok()) << turned.status().message();
  ASSERT_EQ(turned->status, explore::LocalPlanStatus::kTurnInPlace) << turned->message;
  ASSERT_TRUE(turned->plan.trajectory.has_value());
  EXPECT_TRUE(explore::IsCertified(turned->status));
  const planner::WholeBodyTrajectory& trajectory = *turned->plan.trajectory;
  double farthest = 0.0;
  for (double t = 0.0; t <= trajectory.duration(); t += 0.02) {
    farthest = std::max(farthest, (trajectory.Sample(t).position - from.position).norm());
  }
  EXPECT_LT(farthest, 0.1);
  EXPECT_NEAR(std::remainder(trajectory.Sample(trajectory.duration()).yaw - 2.0, 2.0 * M_PI), 0.0, 0.01);
  ExpectInSeenFreeSpace(trajectory, *map);
  EXPECT_FALSE(p.local->PlanTurnFrom(*map, from, std::nan("")).ok());
}

// In a seen-free ball of 0.6 m the robot with its arm out (reaching about
// 0.5 m, kept 0.147 m from the voxel centres not seen free on the default
// map) cannot turn; folded to the joints that hold it nearest its base it
// can, and the turn does.
TEST_F(ExploreTest, FoldsTheArmToTurnInASmallBall) {
  Planner p = MakePlanner(WriteTask(WallAt(5.0), Vec3(8.0, 0.0, 1.2)));
  auto map = perception::RollingMap::Create(perception::RollingMapOptions{});
  ASSERT_TRUE(map.ok());
  const planner::BoundaryState& from = p.base->task().start;
  (*map)->MoveWindow(from.position);
  (*map)->MarkFree(from.position, 0.6);
  auto turned = p.local->PlanTurnFrom(**map, from, 2.0);
  ASSERT_TRUE(turned.ok()) << turned.status().message();
  ASSERT_EQ(turned->status, explore::LocalPlanStatus::kTurnInPlace) << turned->message;
  const planner::WholeBodyTrajectory& trajectory = *turned->plan.trajectory;
  const planner::WholeBodySample end = trajectory.Sample(trajectory.duration());
  EXPECT_GT((end.joints - from.joints).norm(), 0.3) << end.joints.transpose();
  EXPECT_NEAR(std::remainder(end.yaw - 2.0, 2.0 * M_PI), 0.0, 0.01);
  for (double t = 0.0; t <= trajectory.duration(); t += 0.02) {
    ASSERT_LT((trajectory.Sample(t).position - from.position).norm(), 0.1) << t;
  }
  ExpectInSeenFreeSpace(trajectory, **map);

  // A hop from the folded arm keeps it folded (only the plan to the goal
  // unfolds it); the goal, 8 m off, is out of the seen-free ball.
  (*map)->MarkFree(from.position, 1.5);
  planner::BoundaryState folded = end.State();
  folded.velocity = folded.acceleration = folded.jerk = Vec3::Zero();
  folded.yaw_rate = 0.0;
  folded.joint_rates = VecX::Zero(folded.joints.size());
  auto hop = p.local->PlanFrom(**map, folded);
  ASSERT_TRUE(hop.ok()) << hop.status().message();
  ASSERT_EQ(hop->status, explore::LocalPlanStatus::kToLocalTarget) << hop->message;
  const planner::WholeBodyTrajectory& hopped = *hop->plan.trajectory;
  EXPECT_LT((hopped.Sample(hopped.duration()).joints - folded.joints).norm(), 1e-6);
  EXPECT_GT((hopped.Sample(hopped.duration()).position - from.position).norm(), 0.3);
  ExpectInSeenFreeSpace(hopped, **map);
  // From the goal's joints a hop ends with them.
  auto unfolded = p.local->PlanFrom(**map, from);
  ASSERT_TRUE(unfolded.ok()) << unfolded.status().message();
  ASSERT_EQ(unfolded->status, explore::LocalPlanStatus::kToLocalTarget) << unfolded->message;
  EXPECT_LT((unfolded->plan.trajectory->Sample(unfolded->plan.trajectory->duration()).joints -
             p.local->goal().joints).norm(), 1e-6);
}

// Looking round (explore/look_round.h): the goal's bearing first, then the
// rest of the horizon in turns that each take in new headings, until every
// heading has been looked along; a LiDAR's one frame looks all round.
TEST(LookRoundTest, LooksTowardsTheGoalThenRoundTheRestAndStops) {
  const double fov = 87.0 * M_PI / 180.0;
  explore::LookRound look(fov);
  EXPECT_FALSE(look.WasLooked(0.0));
  look.Looked(0.0);
  EXPECT_TRUE(look.WasLooked(0.0) && look.WasLooked(0.7) && look.WasLooked(-0.7));
  EXPECT_FALSE(look.WasLooked(0.9) || look.WasLooked(-0.9) || look.WasLooked(M_PI));
  // The goal behind: turn to face it.
  auto next = look.Next(0.0, 3.0);
  ASSERT_TRUE(next.has_value());
  EXPECT_NEAR(*next, 3.0, 1e-9);
  look.Looked(*next);
  // Then round the rest, each turn taking in the unlooked heading nearest
  // the goal's bearing, until nothing is left.
  double now = *next;
  int turns = 0;
  while (auto heading = look.Next(now, 3.0)) {
    ASSERT_LT(++turns, 8) << "looking round does not end";
    // The view, turned there, takes in a heading not looked along before.
    bool new_heading = false;
    for (double a = -0.5 * fov; a <= 0.5 * fov; a += 0.01) new_heading = new_heading || !look.WasLooked(*heading + a);
    EXPECT_TRUE(new_heading) << *heading;
    look.Looked(*heading);
    now = *heading;
  }
  EXPECT_GE(turns, 2);  // 87 + 87 degrees leave 186 to look along
  for (double a = -M_PI; a < M_PI; a += 0.01) EXPECT_TRUE(look.WasLooked(a)) << a;
  look.Clear();
  EXPECT_FALSE(look.WasLooked(0.0));
  EXPECT_FALSE(look.Next(std::nan(""), 0.0).has_value());

  explore::LookRound lidar(2.0 * M_PI);
  lidar.Looked(1.0);
  EXPECT_FALSE(lidar.Next(1.0, -2.0).has_value());
  // A sensor looking straight down has no heading.
  EXPECT_FALSE(explore::LookRound::HeadingOf(MakePose(Vec3::Zero(), Eigen::AngleAxisd(M_PI / 2, Vec3::UnitY()).toRotationMatrix()),
                                             Vec3::UnitX())
                   .has_value());
  EXPECT_NEAR(*explore::LookRound::HeadingOf(MakePose(Vec3::Zero(), Eigen::AngleAxisd(1.0, Vec3::UnitZ()).toRotationMatrix()),
                                             Vec3::UnitX()),
              1.0, 1e-12);
}

// A vehicle put down facing a wall 0.9 m ahead, its goal 3 m behind it: it
// turns in place to look along the goal's bearing (a plan from rest brings
// the goal no nearer by enough, or none is certified), then flies there,
// and flightcheck agrees; with --no-look-round it holds until it ends stuck.
TEST_F(ExploreTest, TurnsRoundWhenFacingAWallWithTheGoalBehind) {
  const std::string task = WriteTask(WallAt(0.9), Vec3(-3.0, 0.0, 1.2));
  const std::string common = "--stuck-time 3 --time-limit 40";
  const auto r = Explore(task, common);
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  nlohmann::json j = Report();
  EXPECT_EQ(j["outcome"], "arrived");
  auto turns = [](const nlohmann::json& report) {
    int n = 0;
    for (const nlohmann::json& replan : report["replan_log"]) n += replan["status"] == "turn_in_place";
    return n;
  };
  EXPECT_GE(turns(j), 1);
  EXPECT_EQ(j["turns_in_place"], turns(j));
  EXPECT_GE(j["min_clearance_m"].get<double>(), 0.028);
  const auto check = Flightcheck(task);
  EXPECT_EQ(check.exit_code, 0) << check.out << check.err;

  // Without looking round, what it sees leaves no way on: it holds.
  const auto held = Explore(task, common + " --no-look-round");
  EXPECT_EQ(held.exit_code, 1) << held.out << held.err;
  j = Report();
  EXPECT_EQ(j["outcome"], "stuck");
  EXPECT_EQ(turns(j), 0);
}

// The guide tests' wall across the way to their goal (6, 0, 1.2): the
// plane x = 3, |y| <= 2, 0 <= z <= 3, a point every 5 cm.
std::vector<Vec3> GuideTestWall() {
  std::vector<Vec3> wall;
  for (double y = -2.0; y <= 2.0 + 1e-9; y += 0.05) {
    for (double z = 0.0; z <= 3.0 + 1e-9; z += 0.05) wall.emplace_back(3.0, y, z);
  }
  return wall;
}

// The guide (explore/guide.h) against exact lengths: in open space it is
// the straight distance within the 26-neighbour grid's error; round a wall
// it is at least the way round the wall's end, not the straight line
// through it; a goal beyond the window is reached straight from its border.
TEST(GuideTest, MeasuresTheWayRoundWhatWasSeenOccupied) {
  const double cell = 0.4;
  // The grid's metric is at most 1.09 times the straight distance (steps of
  // 1, 1.4 and 1.7 cells), plus the cells at either end.
  // (Lengths are counted in tenths of a cell, rounded: half of one below.)
  auto within = [&](double cost, double exact) {
    return cost >= exact - 0.05 * cell - 1e-6 && cost <= 1.09 * exact + 2.0 * cell;
  };
  auto map = perception::RollingMap::Create(perception::RollingMapOptions{});
  ASSERT_TRUE(map.ok());
  (*map)->MoveWindow(Vec3(0.0, 0.0, 1.2));
  const Vec3 goal(6.0, 0.0, 1.2);
  {
    const explore::Guide open = explore::Guide::Compute(**map, goal, cell, 1.0);
    EXPECT_EQ(open.blocked_cells(), 0);
    for (const Vec3& p : {Vec3(0.0, 0.0, 1.2), Vec3(-5.0, 4.0, 1.5), Vec3(6.1, -0.2, 1.1), Vec3(2.0, -7.0, 0.5)}) {
      const double exact = (p - goal).norm();
      // Never shorter than the straight line (every centre's way is at
      // least its straight distance; p goes on straight to a centre).
      EXPECT_TRUE(within(open.CostAt(p), exact)) << p.transpose() << ": " << open.CostAt(p);
    }
    // Outside the searched layers (the goal's height +- 1 m and a cell).
    EXPECT_EQ(open.CostAt(Vec3(0.0, 0.0, 4.0)), explore::Guide::kUnreachable);
    EXPECT_EQ(open.CostAt(Vec3(NAN, 0.0, 1.2)), explore::Guide::kUnreachable);
  }
  // A wall x = 3, |y| <= 2, 0 <= z <= 3 (beyond the searched layers), seen
  // from the origin's side: the way from (0, 0) goes round an end.
  ASSERT_TRUE((*map)->Insert(GuideTestWall(), Vec3(0.0, 0.0, 1.2)).ok());
  const explore::Guide round = explore::Guide::Compute(**map, goal, cell, 1.0);
  EXPECT_GT(round.blocked_cells(), 0);
  const Vec3 p(0.0, 0.0, 1.2), end(3.0, 2.0, 1.2);
  const double way_round = (end - p).norm() + (goal - end).norm();  // 7.21 m, against 6 straight
  const double cost = round.CostAt(p);
  EXPECT_GE(cost, way_round - cell) << cost;
  EXPECT_LE(cost, 1.09 * way_round + 2.0 * cell) << cost;
  // Near an end the way is shorter than from the middle of the wall.
  EXPECT_LT(round.CostAt(Vec3(2.5, 2.6, 1.2)), round.CostAt(Vec3(2.5, 0.0, 1.2)));
  // A goal beyond the window (its half extent is 15 m): straight on from the border.
  const Vec3 far(40.0, 0.0, 1.2);
  const explore::Guide beyond = explore::Guide::Compute(**map, far, cell, 1.0);
  EXPECT_TRUE(within(beyond.CostAt(Vec3(10.0, 0.0, 1.2)), 30.0))
      << beyond.CostAt(Vec3(10.0, 0.0, 1.2));
  // Walled in on every side in the searched layers: unreachable.
  auto boxed = perception::RollingMap::Create(perception::RollingMapOptions{});
  ASSERT_TRUE(boxed.ok());
  (*boxed)->MoveWindow(Vec3(0.0, 0.0, 1.2));
  std::vector<Vec3> shell;
  for (double a = -1.0; a <= 1.0 + 1e-9; a += 0.05) {
    for (double z = -0.6; z <= 3.0 + 1e-9; z += 0.05) {
      shell.emplace_back(a, -1.0, z);
      shell.emplace_back(a, 1.0, z);
      shell.emplace_back(-1.0, a, z);
      shell.emplace_back(1.0, a, z);
    }
  }
  ASSERT_TRUE((*boxed)->Insert(shell, Vec3(0.0, 0.0, 1.2)).ok());
  EXPECT_EQ(explore::Guide::Compute(**boxed, goal, cell, 1.0).CostAt(Vec3(0.0, 0.0, 1.2)), explore::Guide::kUnreachable);
}

// A wall known only from a prior map (RollingMap::SetPrior) is one the
// guide goes round, as one the sensor saw: the way from behind it is the
// way round its end, where the map without the prior gives the straight
// line. Unknown space is open to the guide; the prior's obstacles are not.
TEST(GuideTest, GoesRoundAWallKnownFromAPriorMap) {
  const double cell = 0.4;
  const Vec3 goal(6.0, 0.0, 1.2), p(0.0, 0.0, 1.2), end(3.0, 2.0, 1.2);
  auto unseen = perception::RollingMap::Create(perception::RollingMapOptions{});
  auto known = perception::RollingMap::Create(perception::RollingMapOptions{});
  ASSERT_TRUE(unseen.ok() && known.ok());
  for (auto* map : {&*unseen, &*known}) {
    (*map)->MoveWindow(p);
    (*map)->MarkFree(p, 0.8);
  }
  ASSERT_TRUE((*known)->SetPrior(GuideTestWall()).ok());
  const double straight = explore::Guide::Compute(**unseen, goal, cell, 1.0).CostAt(p);
  EXPECT_LE(straight, 1.09 * (goal - p).norm() + 2.0 * cell) << straight;
  const explore::Guide round = explore::Guide::Compute(**known, goal, cell, 1.0);
  EXPECT_GT(round.blocked_cells(), 0);
  const double way_round = (end - p).norm() + (goal - end).norm();  // 7.21 m, against 6 straight
  EXPECT_GE(round.CostAt(p), way_round - cell) << round.CostAt(p);
  EXPECT_LE(round.CostAt(p), 1.09 * way_round + 2.0 * cell) << round.CostAt(p);
}

// The pocket (WritePocketTask): the seen point nearest the goal is inside
// it, where ranking targets by the straight distance holds the vehicle for
// good (the flight ends stuck). Ranked along the guide it flies out and
// round.
TEST_F(ExploreTest, LeavesADeadEndAlongTheGuide) {
  const std::string task = WritePocketTask();
  const auto r = Explore(task, "--guide-cell 0.4");
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  const nlohmann::json j = Report();
  EXPECT_EQ(j["outcome"], "arrived");
  EXPECT_TRUE(j["kept_clearance"].get<bool>());
  const auto check = Flightcheck(task);
  EXPECT_EQ(check.exit_code, 0) << check.out << check.err;
  // (Without the guide, the default, the same flight ends stuck in the
  // pocket: docs/perception.md. Not run here: it takes a minute to fail.)
}

// The same pocket known in advance (its scene as a prior map, --prior):
// the guide routes round it from the start, and the vehicle comes no
// further than 0.8 m into it (0.49 m measured; 1.14 m without the prior,
// docs/perception.md, "A prior map"), arrives, and keeps its clearance.
TEST_F(ExploreTest, WithAPriorMapTheGuideGoesRoundTheDeadEndFromTheStart) {
  const std::string task = WritePocketTask();
  const auto r = Explore(task, "--guide-cell 0.4 --prior " + task);
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  const nlohmann::json j = Report();
  EXPECT_EQ(j["outcome"], "arrived");
  EXPECT_TRUE(j["kept_clearance"].get<bool>());
  EXPECT_GT(j["prior_points"].get<size_t>(), 10000u);
  const auto check = Flightcheck(task);
  EXPECT_EQ(check.exit_code, 0) << check.out << check.err;
  auto loaded = planner::LoadTask(task);
  ASSERT_TRUE(loaded.ok());
  auto robot = robot::RobotModel::LoadFromUrdfFile(loaded->robot_path);
  ASSERT_TRUE(robot.ok());
  auto record = sim::LoadPlanCsv(flown_, robot->ActuatedJointNames());
  ASSERT_TRUE(record.ok()) << record.status().message();
  double deepest = -1e9;  // the farthest x inside the pocket
  for (const sim::PlanRow& sample : record->rows) {
    if (std::abs(sample.position.y()) < 2.0 && sample.position.x() < 3.0) {
      deepest = std::max(deepest, sample.position.x());
    }
  }
  EXPECT_LT(deepest, 0.8) << deepest;
}

// The posts, no floor (support/posts_world.h).
std::vector<Vec3> Posts() { return testing::PostsWorld(/*with_floor=*/false); }

TEST_F(ExploreTest, FliesPastPostsItHasNeverSeenAndKeepsTheClearance) {
  const std::string task = WriteTask(Posts(), Vec3(8.0, 0.0, 1.2));
  const auto r = Explore(task);
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  const nlohmann::json j = Report();
  EXPECT_EQ(j["outcome"], "arrived");
  EXPECT_TRUE(j["success"].get<bool>());
  EXPECT_TRUE(j["kept_clearance"].get<bool>());
  EXPECT_GE(j["min_clearance_m"].get<double>(), 0.028);
  EXPECT_LT(j["goal_distance_m"].get<double>(), 0.15);
  EXPECT_GT(j["replans_certified"].get<int>(), 1);  // it did not see the goal from the start
  EXPECT_GT(j["frames"].get<int>(), 10);
  // The independent judge agrees.
  const auto check = Flightcheck(task);
  EXPECT_EQ(check.exit_code, 0) << check.out << check.err;
}

// A mission of reaches at rest is flown leg by leg on the same map: the
// vehicle comes to rest at the first reach (past the first post) before it
// plans for the second, and the whole flight keeps the clearance.
TEST_F(ExploreTest, FliesAMissionOfReachesLegByLeg) {
  const std::string cloud = (dir_ / "posts.pcd").string();
  ASSERT_TRUE(scene::WritePcd(cloud, Posts()).ok());
  const std::string task = (dir_ / "mission.yaml").string();
  std::ofstream(task) << "robot: " << QUADHAND_SOURCE_DIR << "/meshes/quadhand/quadhand.urdf\n"
                      << "sdf_dir: " << testing::CoarseSdfDir() << "\n"
                      << "scene: " << cloud << "\n"
                      << "start: {position: [0.0, 0.0, 1.2], yaw: 0.0, joints: [0.3, -0.2, 0.0]}\n"
                      << "mission:\n"
                      << "  - reach: {position: [4.2, 0.0, 1.2], yaw: 0.0, joints: [0.3, -0.2, 0.0]}\n"
                      << "  - reach: {position: [8.0, 0.0, 1.4], yaw: 1.0, joints: [0.3, -0.2, 0.0]}\n"
                      << "limits: {v_max: 2.0, a_max: 4.0, yaw_rate_max: 1.5, body_rate_xy_max: 3.0}\n"
                      << "safety_distance: 0.03\n";
  auto loaded = planner::LoadTask(task);
  ASSERT_TRUE(loaded.ok()) << loaded.status().message();
  auto legs = explore::LegsOfTask(*loaded);
  ASSERT_TRUE(legs.ok()) << legs.status().message();
  ASSERT_EQ(legs->size(), 2u);
  EXPECT_TRUE((*legs)[1].start.position.isApprox(Vec3(4.2, 0.0, 1.2)));  // where the first leg ends
  EXPECT_TRUE((*legs)[1].terminal->position.isApprox(Vec3(8.0, 0.0, 1.4)));

  const auto r = Explore(task);
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  const nlohmann::json j = Report();
  EXPECT_EQ(j["outcome"], "arrived");
  EXPECT_EQ(j["legs"], 2);
  EXPECT_EQ(j["legs_arrived"], 2);
  EXPECT_GE(j["min_clearance_m"].get<double>(), 0.028);
  EXPECT_LT(j["goal_distance_m"].get<double>(), 0.15);
  // Every replan of the second leg comes after the first leg's last.
  double last_of_first = -1.0, first_of_second = 1e9;
  for (const nlohmann::json& replan : j["replan_log"]) {
    if (replan["leg"] == 0) last_of_first = std::max(last_of_first, replan["t"].get<double>());
    if (replan["leg"] == 1) first_of_second = std::min(first_of_second, replan["t"].get<double>());
  }
  ASSERT_GE(last_of_first, 0.0);
  ASSERT_LT(first_of_second, 1e9);
  EXPECT_LT(last_of_first, first_of_second);
  // The vehicle stood at the first reach when the second leg was planned.
  auto robot = robot::RobotModel::LoadFromUrdfFile(loaded->robot_path);
  ASSERT_TRUE(robot.ok());
  auto record = sim::LoadPlanCsv(flown_, robot->ActuatedJointNames());
  ASSERT_TRUE(record.ok()) << record.status().message();
  double nearest = 1e9, speed_there = 1e9;
  for (const sim::PlanRow& sample : record->rows) {
    if (std::abs(sample.t - first_of_second) < 0.006) {
      nearest = (sample.position - Vec3(4.2, 0.0, 1.2)).norm();
      speed_there = sample.velocity.norm();
    }
  }
  EXPECT_LT(nearest, 0.15);
  EXPECT_LT(speed_there, 0.1);
  const auto check = Flightcheck(task);
  EXPECT_EQ(check.exit_code, 0) << check.out << check.err;
}

// A wall 2 m ahead whose only opening is the paper's 0.6 x 0.35 m gap
// (centre z = 1.2 m): the map's certificate at 0.1 m voxels keeps 0.147 m
// from every voxel centre not seen free, which closes it; at 0.05 m with no
// tracking margin the vehicle finds the gap when it sees it and flies
// through, and the local planner's front end and far grid follow the
// map's voxel so that they do not close it either.
TEST_F(ExploreTest, FliesThroughANarrowGapItHasNeverSeenOnAFinerMap) {
  planner::PlannerConfig config = planner::DefaultPlannerConfig();
  explore::UseLocalPlanningDefaults(&config, 0.05);
  EXPECT_DOUBLE_EQ(config.front_end.voxel_size, 0.05);
  EXPECT_DOUBLE_EQ(config.representations.mrc_sdf.far_cell_size, 0.05);
  EXPECT_EQ(config.representations.mrc_sdf.far_max_steps, 20);
  explore::UseLocalPlanningDefaults(&config);
  EXPECT_DOUBLE_EQ(config.front_end.voxel_size, 0.1);
  EXPECT_EQ(config.representations.mrc_sdf.far_max_steps, 10);
  explore::UseLocalPlanningDefaults(&config, 0.01);  // the front end's grid would grow by the cube
  EXPECT_DOUBLE_EQ(config.front_end.voxel_size, 0.05);
  explore::UseLocalPlanningDefaults(&config, std::nan(""));
  EXPECT_DOUBLE_EQ(config.front_end.voxel_size, 0.1);

  std::vector<Vec3> world;
  for (double y = -2.0; y <= 2.0 + 1e-9; y += 0.02) {
    for (double z = 0.0; z <= 2.6 + 1e-9; z += 0.02) {
      if (std::abs(y) < 0.3 && std::abs(z - 1.2) < 0.175) continue;
      world.emplace_back(2.0, y, z);
    }
  }
  for (double x = -1.0; x <= 4.0 + 1e-9; x += 0.02) {  // a floor, a ceiling and side walls: no way round
    for (double y = -2.0; y <= 2.0 + 1e-9; y += 0.02) {
      world.emplace_back(x, y, 0.0);
      world.emplace_back(x, y, 2.6);
    }
    for (double z = 0.0; z <= 2.6 + 1e-9; z += 0.02) {
      world.emplace_back(x, -2.0, z);
      world.emplace_back(x, 2.0, z);
    }
  }
  const std::string task = WriteTask(world, Vec3(3.2, 0.0, 1.2));
  const auto r = Explore(task, "--resolution 0.05 --tracking-margin 0 --window 6,6,3");
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  const nlohmann::json j = Report();
  EXPECT_EQ(j["outcome"], "arrived");
  EXPECT_GE(j["min_clearance_m"].get<double>(), 0.028);
  EXPECT_NEAR(j["planned_safety_distance_m"].get<double>(), 0.03 + std::sqrt(3.0) * 0.025, 1e-9);
  const auto check = Flightcheck(task);
  EXPECT_EQ(check.exit_code, 0) << check.out << check.err;
}

// Frames recorded along a straight flight past the posts (rendered here as
// a recording would hold them: the sensor's pose and its returns), replanned
// over: a replan every period of the recording's time, from where its
// vehicle was and as fast as it went, and every certified plan keeps the
// safety distance from the true world, which the planner never saw whole.
TEST_F(ExploreTest, ReplansOverRecordedFramesFromWhereTheVehicleWas) {
  const std::vector<Vec3> world = Posts();
  const std::string task_path = WriteTask(world, Vec3(8.0, 0.0, 1.2));
  Planner p = MakePlanner(task_path);
  sim::SensorConfig sensor;  // a depth camera on base_link, the default mount
  auto renderer = sim::SensorRenderer::Create(world, sensor, 7);
  ASSERT_TRUE(renderer.ok()) << renderer.status().message();
  explore::RecordedReplanOptions options;
  options.mount = sensor.Mount();
  EXPECT_FALSE(explore::RecordedReplanner::Create(*p.local, p.base->task(), [&] {
                 explore::RecordedReplanOptions bad = options;
                 bad.replan_period = 0.0;
                 return bad;
               }()).ok());
  auto replanner = explore::RecordedReplanner::Create(*p.local, p.base->task(), options);
  ASSERT_TRUE(replanner.ok()) << replanner.status().message();
  auto map = perception::RollingMap::Create(perception::RollingMapOptions{});
  ASSERT_TRUE(map.ok());
  // 2 s at 0.5 m/s along x from the task's start, 10 frames a second.
  const Vec3 speed(0.5, 0.0, 0.0);
  std::vector<explore::RecordedReplan> replans;
  for (int k = 0; k <= 20; ++k) {
    const double t = 0.1 * k;
    const Pose sensor_pose = MakePose(Vec3(0.0, 0.0, 1.2) + t * speed, Mat3::Identity()) * sensor.Mount();
    std::vector<Vec3> seen = (*renderer)->Render(sensor_pose);
    for (Vec3& q : seen) q = sensor_pose * q;
    replanner->BeforeFrame(map->get(), sensor_pose);
    (*map)->MoveWindow(sensor_pose.translation());
    ASSERT_TRUE((*map)->Insert(seen, sensor_pose.translation()).ok());
    if (auto r = replanner->AfterFrame(**map, t, sensor_pose)) replans.push_back(std::move(*r));
  }
  ASSERT_EQ(replans.size(), 5u);  // at 0, 0.5, 1, 1.5 and 2 s
  auto judge = planner::PlanningContext::Create(p.base->task(), p.base->robot(),
                                                std::make_shared<const std::vector<Vec3>>(world), 0,
                                                planner::ContextOptions(planner::DefaultPlannerConfig(), {}));
  ASSERT_TRUE(judge.ok()) << judge.status().message();
  robot::KinematicsState kinematics;
  int certified = 0;
  for (size_t n = 0; n < replans.size(); ++n) {
    const explore::RecordedReplan& r = replans[n];
    EXPECT_NEAR(r.t, 0.5 * static_cast<double>(n), 1e-9);
    EXPECT_LT((r.start.position - (Vec3(0.0, 0.0, 1.2) + r.t * speed)).norm(), 1e-9);
    EXPECT_NEAR(r.start.yaw, 0.0, 1e-9);
    // At rest before any frame is a window old; then the recording's speed.
    EXPECT_LT((r.start.velocity - (n == 0 ? Vec3::Zero() : speed)).norm(), 1e-9) << r.start.velocity.transpose();
    const bool ok = r.result.status == explore::LocalPlanStatus::kToGoal ||
                    r.result.status == explore::LocalPlanStatus::kToLocalTarget;
    if (!ok) continue;
    ++certified;
    const planner::WholeBodyTrajectory& trajectory = *r.result.plan.trajectory;
    EXPECT_LT((trajectory.Sample(0.0).position - r.start.position).norm(), 1e-6);
    for (double tau = 0.0; tau <= trajectory.duration(); tau += 0.02) {
      const planner::WholeBodySample s = trajectory.Sample(tau);
      robot::ComputeKinematics((*judge)->robot(), s.BasePose(), s.joints, &kinematics);
      const double d =
          planner::StillAndMovingClearance(kinematics, (*judge)->exact(), nullptr, Pose::Identity(), 1.0);
      ASSERT_GE(d, 0.03 - 0.002) << "replan at " << r.t << " s, plan time " << tau;
    }
  }
  // (Open loop, the recording flies on whatever was planned: here straight
  // at the first post, which leaves some replans without a certified plan.)
  EXPECT_GE(certified, 2);
}

// Frames faulted on their way: a silence (the vehicle brakes along its plan
// and holds, then goes on when frames return) and spoiled frames (each
// dropped by the gate for its reason, or its NaN returns by the map), and
// the flight still arrives with its clearance.
TEST_F(ExploreTest, BrakesAndHoldsWhileTheSensorIsSilentAndDropsBadFrames) {
  const std::string task = WriteTask(Posts(), Vec3(8.0, 0.0, 1.2));
  const auto r = Explore(task, "--silence 1.5-3.5 --bad-frames 0.3");
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  const nlohmann::json j = Report();
  EXPECT_TRUE(j["success"].get<bool>());
  EXPECT_GE(j["min_clearance_m"].get<double>(), 0.028);

  const nlohmann::json& dropped = j["frames_dropped"];
  const nlohmann::json& injected = j["faults_injected"];
  EXPECT_GT(injected["silenced"].get<int>(), 50);  // 2 s at 30 Hz
  for (const char* kind : {"nan_pose", "unnormalised_attitude", "future_stamp", "late", "nan_points"}) {
    EXPECT_GT(injected[kind].get<int>(), 0) << kind;
  }
  EXPECT_EQ(dropped["malformed"], injected["nan_pose"]);
  EXPECT_EQ(dropped["bad_pose"], injected["unnormalised_attitude"]);
  EXPECT_EQ(dropped["from_the_future"], injected["future_stamp"]);
  // A late frame behind one already taken; not when the next was late too.
  EXPECT_GT(dropped["out_of_order"].get<int>(), 0);
  EXPECT_LE(dropped["out_of_order"].get<int>(), injected["late"].get<int>());
  EXPECT_GT(j["returns_dropped"].get<long>(), 0);

  // The silence: timed out sensor_timeout after the last frame, braked from
  // flight, ended at the first good frame after it.
  const nlohmann::json* silence = nullptr;
  for (const nlohmann::json& s : j["silences"]) {
    if (s["from"].get<double>() >= 1.5 && s["from"].get<double>() <= 1.5 + 0.3 + 0.05) silence = &s;
  }
  ASSERT_NE(silence, nullptr) << j["silences"].dump();
  EXPECT_TRUE((*silence)["ended"].get<bool>());
  // (The first frames after it may be spoiled too.)
  EXPECT_GE((*silence)["to"].get<double>(), 3.5 - 1e-6);
  EXPECT_LT((*silence)["to"].get<double>(), 3.5 + 0.25);
  EXPECT_GT((*silence)["braked_from_speed"].get<double>(), 0.1);
  const double stopped = (*silence)["from"].get<double>() + (*silence)["brake_s"].get<double>();
  ASSERT_LT(stopped, 3.0);
  // Held: from half a second after the brake ends until frames return, the
  // vehicle's own states barely move.
  std::ifstream csv(flown_);
  std::string line;
  std::getline(csv, line);
  const std::vector<std::string> header = core::TrimmedFields(line);
  const auto column = [&](const std::string& name) {
    return static_cast<size_t>(std::find(header.begin(), header.end(), name) - header.begin());
  };
  const size_t t_col = column("t"), vx = column("vx"), vy = column("vy"), vz = column("vz");
  ASSERT_LT(vz, header.size());
  int held = 0;
  while (std::getline(csv, line)) {
    const std::vector<std::string> cells = core::TrimmedFields(line);
    const double t = std::stod(cells[t_col]);
    if (t < stopped + 0.5 || t > 3.5) continue;
    const Vec3 v(std::stod(cells[vx]), std::stod(cells[vy]), std::stod(cells[vz]));
    EXPECT_LT(v.norm(), 0.1) << "t " << t;
    ++held;
  }
  EXPECT_GT(held, 20);
  const auto check = Flightcheck(task);
  EXPECT_EQ(check.exit_code, 0) << check.out << check.err;
}

// An obstacle appears across the way, in space the map had seen free, while
// the vehicle flies a plan through it and no periodic replan is due for
// seconds: the frames that see it turn its voxels occupied, the plan ahead
// is found crossing them, the vehicle brakes along its plan and replans at
// once around it. (Without the check it flies into the patch.)
TEST_F(ExploreTest, APlanCrossedByANewObstacleBrakesAndReplansAroundIt) {
  const std::string task = WriteTask(Posts(), Vec3(8.0, 0.0, 1.2));
  std::vector<Vec3> patch;
  for (double y = -1.6; y <= 1.6 + 1e-9; y += 0.04) {
    for (double z = 0.3; z <= 2.1 + 1e-9; z += 0.04) patch.emplace_back(2.5, y, z);
  }
  const std::string appear = (dir_ / "patch.pcd").string();
  ASSERT_TRUE(scene::WritePcd(appear, patch).ok());
  const auto r = Explore(task, "--appear " + appear + " --appear-at 0.5 --replan-period 4 --time-limit 80");
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err << testing::ReadAll(report_);
  const nlohmann::json j = Report();
  EXPECT_TRUE(j["success"].get<bool>());
  ASSERT_FALSE(j["invalidations"].empty());
  const nlohmann::json& first = j["invalidations"][0];
  EXPECT_TRUE(first["flown_plan"].get<bool>());
  EXPECT_GE(first["t"].get<double>(), 0.5);
  EXPECT_LT(first["t"].get<double>(), 0.5 + 0.3);  // a few frames to change a free voxel's mind
  EXPECT_GT(first["stop_margin_s"].get<double>(), 0.0);  // it stopped before the conflict
  EXPECT_GT(first["new_obstacle_voxels"].get<int>(), 10);
  // (--time-limit: with a replan every 4 s the way round takes longer than
  // the default limit from the straight line allows.)
  // The judge after the patch appeared: the world with it.
  std::vector<Vec3> with_patch = Posts();
  with_patch.insert(with_patch.end(), patch.begin(), patch.end());
  const std::string judged = WriteTask(with_patch, Vec3(8.0, 0.0, 1.2), "with_patch");
  const auto check = Flightcheck(judged);
  EXPECT_EQ(check.exit_code, 0) << check.out << check.err;
}

// The fault injector itself: silences stop everything; a late frame comes
// after the next one.
TEST(SensorFaultsTest, SilencesStopFramesAndLateFramesComeAfterTheNext) {
  explore::SensorFaultOptions options;
  options.silences = {{1.0, 2.0}};
  explore::SensorFaults silent(options, 1);
  perception::SensorFrame frame;
  frame.t = 1.5;
  EXPECT_TRUE(silent.Pass(frame, 1.5).empty());
  frame.t = 2.0;
  EXPECT_EQ(silent.Pass(frame, 2.0).size(), 1u);
  EXPECT_EQ(silent.counts().silenced, 1);

  options.silences.clear();
  options.bad_frame_probability = 1.0;
  explore::SensorFaults spoiling(options, 7);
  long late = 0, arrived = 0;
  for (int k = 0; k < 200; ++k) {
    frame.t = 0.1 * k;
    frame.position = Vec3::Zero();
    frame.attitude = Eigen::Vector4d(1.0, 0.0, 0.0, 0.0);
    frame.points = std::vector<Vec3>(20, Vec3(1.0, 0.0, 0.0));
    const std::vector<perception::SensorFrame> out = spoiling.Pass(frame, frame.t);
    arrived += static_cast<long>(out.size());
    for (size_t i = 1; i < out.size(); ++i) EXPECT_LT(out[i].t, out[0].t);  // held back ones come after
  }
  for (int k = 0; k < explore::kNumSensorFaultKinds; ++k) EXPECT_GT(spoiling.counts().spoiled[k], 10) << k;
  late = spoiling.counts().spoiled[static_cast<int>(explore::SensorFaultKind::kLate)];
  EXPECT_GE(arrived, 200 - 1);  // all but perhaps the last, held at the end
  EXPECT_GT(late, 0);

  explore::SensorFaultOptions::Window window;
  EXPECT_TRUE(explore::ParseSilence("2.5-4", &window));
  EXPECT_DOUBLE_EQ(window.from, 2.5);
  EXPECT_DOUBLE_EQ(window.to, 4.0);
  for (const char* bad : {"4-2", "x-3", "3", "-1-2", "1-", "1-nan"}) EXPECT_FALSE(explore::ParseSilence(bad, &window)) << bad;
}

// The bundled gap-crossing grasp under perception: the reach that grasps,
// its grasp and the lift are the grasp's work; exploration ends at the
// staging state, 0.15 m before the insertion's start along its axis; the
// grasp map's box holds the robot at every state of the work and the cup.
// A mission whose grasp could not be flown is refused naming the step.
TEST(GraspUnderPerceptionTest, TheWorkOfTheGapCrossingGrasp) {
  auto task = planner::LoadTask(std::string(QUADHAND_SOURCE_DIR) + "/data/tasks/missions/gap_crossing_grasp.yaml");
  ASSERT_TRUE(task.ok()) << task.status().message();
  auto robot = robot::RobotModel::LoadFromUrdfFile(task->robot_path);
  ASSERT_TRUE(robot.ok());
  const explore::GraspOptions options;
  auto work = explore::GraspWorkOfTask(*task, *robot, options);
  ASSERT_TRUE(work.ok()) << work.status().message();
  ASSERT_TRUE(work->has_value());
  const explore::GraspWork& w = **work;
  EXPECT_EQ(w.reach_step, 0u);
  ASSERT_EQ(w.steps.size(), 3u);
  EXPECT_EQ(w.steps[1].kind, planner::StepKind::kGrasp);
  const Vec3 reach = task->mission[0].reach_state->position;
  EXPECT_TRUE(w.staging.position.isApprox(reach + Vec3(0.0, 0.0, 0.10 + options.approach), 1e-12));
  EXPECT_DOUBLE_EQ(w.staging.yaw, task->mission[0].reach_state->yaw);
  EXPECT_TRUE(w.tool_position.isApprox(Vec3(-2.2, 0.0, 0.56)));
  // The box: the cup, the staging base with its rotor guards (0.18 m) and
  // the lift's end, with the margin round them.
  for (const Vec3& inside : std::vector<Vec3>{Vec3(-2.2, 0.0, 0.55),
                                              w.staging.position + Vec3(0.17 + options.box_margin, 0.0, 0.0),
                                              reach + Vec3(0.0, 0.0, 0.15)}) {
    EXPECT_TRUE((inside.array() > w.box_lo.array()).all() && (inside.array() < w.box_hi.array()).all())
        << inside.transpose();
  }
  EXPECT_LT((w.box_hi - w.box_lo).maxCoeff(), 1.5);  // about the work, not the room
  auto legs = explore::LegsOfTask(*task, &w);
  ASSERT_TRUE(legs.ok()) << legs.status().message();
  ASSERT_EQ(legs->size(), 1u);
  EXPECT_TRUE((*legs)[0].terminal->position.isApprox(w.staging.position));
  auto without = explore::LegsOfTask(*task);
  ASSERT_FALSE(without.ok());

  planner::Task no_grasp = *task;
  no_grasp.mission.resize(1);
  no_grasp.mission[0].reach_tool.reset();
  auto none = explore::GraspWorkOfTask(no_grasp, *robot, options);
  ASSERT_TRUE(none.ok());
  EXPECT_FALSE(none->has_value());
  planner::Task no_insertion = *task;
  no_insertion.mission[0].reach_tool->has_insertion = false;
  planner::Task no_state = *task;
  no_state.mission[0].reach_state.reset();
  planner::Task released = *task;
  released.mission.push_back(planner::MissionStep{});
  released.mission.back().kind = planner::StepKind::kRelease;
  for (const auto& [bad, expect] : std::vector<std::pair<planner::Task, std::string>>{
           {no_insertion, "mission[0] (reach)"}, {no_state, "mission[0] (reach)"}, {released, "mission[3] (release)"}}) {
    auto refused = explore::GraspWorkOfTask(bad, *robot, options);
    ASSERT_FALSE(refused.ok()) << expect;
    EXPECT_NE(refused.status().message().find(expect), std::string::npos) << refused.status().message();
  }
  explore::GraspOptions bad_options;
  bad_options.resolution = 0.0;
  EXPECT_FALSE(explore::GraspWorkOfTask(*task, *robot, bad_options).ok());
}

// The grasp map about a cup on a table, seen from three sides: what it
// plans against keeps out the voxels within scene_margin plus the ball
// radius of the declared cup (taken to be the cup's, as a scan's points
// within scene_margin are) and nothing else: the table's surface beside the
// cup and the box's faces stay.
TEST(GraspUnderPerceptionTest, TheGraspMapLeavesOutOnlyTheObjectsVoxels) {
  explore::GraspWork work;
  work.object.shape.kind = planner::ObjectShape::Kind::kCylinder;
  work.object.shape.radius = 0.04;
  work.object.shape.length = 0.10;
  work.object.pose = MakePose(Vec3(0.0, 0.0, 0.55), Mat3::Identity());
  work.scene_margin = 0.01;
  work.box_lo = Vec3(-0.3, -0.3, 0.45);
  work.box_hi = Vec3(0.3, 0.3, 0.9);
  std::vector<Vec3> scene;
  for (double x = -0.5; x <= 0.5; x += 0.004) {
    for (double y = -0.5; y <= 0.5; y += 0.004) scene.emplace_back(x, y, 0.5);  // the table
  }
  for (double z = 0.5; z <= 0.6; z += 0.003) {
    for (int k = 0; k < 90; ++k) {
      const double a = 2.0 * M_PI * k / 90.0;
      scene.emplace_back(0.04 * std::cos(a), 0.04 * std::sin(a), z);
    }
  }
  const explore::GraspOptions options;
  auto map = explore::GraspMap::Create(work, options, perception::RollingMapOptions{});
  ASSERT_TRUE(map.ok()) << map.status().message();
  // Each ray's return: the scene point nearest the sensor within 3 mm of it.
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> spread(-0.25, 0.25);
  for (const Vec3& origin : {Vec3(1.0, 0.0, 1.0), Vec3(0.0, 1.0, 1.0), Vec3(-1.0, -0.3, 1.0)}) {
    std::vector<Vec3> points;
    for (int k = 0; k < 6000; ++k) {
      const Vec3 aim = Vec3(spread(rng), spread(rng), 0.5 + 0.5 * (spread(rng) + 0.25));
      const Vec3 u = (aim - origin).normalized();
      double best = std::numeric_limits<double>::infinity();
      for (const Vec3& q : scene) {
        const double along = (q - origin).dot(u);
        if (along > 0.0 && along < best && ((q - origin) - along * u).norm() < 0.003) best = along;
      }
      if (std::isfinite(best)) points.push_back(origin + best * u);
    }
    ASSERT_TRUE((*map)->Insert(points, origin, {}).ok());
  }
  const double keep_off = work.scene_margin + (*map)->BallRadius();
  const std::vector<Vec3> boundary = (*map)->map().ObstacleBoundary(work.box_lo, work.box_hi);
  const std::vector<Vec3> obstacles = (*map)->Obstacles();
  size_t near_cup = 0, table = 0, faces = 0;
  for (const Vec3& c : boundary) near_cup += planner::DistanceToObjectSurface(work.object, c) <= keep_off ? 1 : 0;
  for (const Vec3& c : obstacles) {
    EXPECT_GT(planner::DistanceToObjectSurface(work.object, c), keep_off) << c.transpose();
    table += std::abs(c.z() - 0.5) < 0.01 && c.head<2>().norm() > 0.1 ? 1 : 0;
    faces += ((c - work.box_lo).cwiseAbs().minCoeff() < 0.006 || (c - work.box_hi).cwiseAbs().minCoeff() < 0.006) ? 1 : 0;
  }
  EXPECT_GT(near_cup, 100u);
  EXPECT_EQ(obstacles.size() + near_cup, boundary.size());
  EXPECT_GT(table, 100u);
  EXPECT_GT(faces, 100u);
}

// The gap-crossing grasp's cup on its cube, in the open (a floor, nothing
// else), from 1.5 m: the vehicle flies to the staging state on what its
// camera sees, the grasp is planned on the grasp map and flown, the gripper
// closes with the flown tool within 1 cm of the reach's tool point, and the
// lift ends it; the record's gripper column lets quadhand-flightcheck judge
// the mission against the true world. The world's discs are no wider than
// its sampling (splat_spacing_factor): with 2 cm discs the cup is drawn
// 2 cm fatter than it is, and the grasp is not certified (the fingers pass
// 3.5 cm from it).
TEST_F(ExploreTest, GraspsACupOnTheGraspMap) {
  const std::string task = WriteGraspTask(CupOnCubeWorld(), "grasp", {"position: [-0.7, 0.1, 1.15]"});
  const std::string dense = WriteSimConfig({"splat_spacing_factor: 0.75"});
  const std::string options = "--resolution 0.05 --tracking-margin 0 --window 6,6,3";

  const auto r = Explore(task, options + " --sim-config " + dense);
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  nlohmann::json j = Report();
  EXPECT_EQ(j["outcome"], "arrived");
  ASSERT_TRUE(j["grasp"]["closed"].get<bool>());
  EXPECT_LT(j["grasp"]["tool_error_m"].get<double>(), 0.01);
  EXPECT_TRUE(j["grasp"]["attempts"].back()["certified"].get<bool>());
  EXPECT_NEAR(j["grasp"]["planned_safety_distance_m"].get<double>(), 0.03 + std::sqrt(3.0) * 0.0025, 1e-9);
  auto robot = robot::RobotModel::LoadFromUrdfFile(std::string(QUADHAND_SOURCE_DIR) + "/meshes/quadhand/quadhand.urdf");
  ASSERT_TRUE(robot.ok());
  auto record = sim::LoadPlanCsv(flown_, robot->ActuatedJointNames());
  ASSERT_TRUE(record.ok()) << record.status().message();
  int closings = 0;
  for (size_t k = 1; k < record->rows.size(); ++k) {
    closings += record->rows[k - 1].gripper == 0 && record->rows[k].gripper == 1 ? 1 : 0;
  }
  EXPECT_EQ(closings, 1);
  EXPECT_EQ(record->rows.back().gripper, 1);
  const auto check = Flightcheck(task);
  EXPECT_EQ(check.exit_code, 0) << check.out << check.err;
  EXPECT_NE(check.out.find("1 gripper events"), std::string::npos) << check.out;

  const auto fat = Explore(task, options);
  EXPECT_EQ(fat.exit_code, 1) << fat.out << fat.err;
  j = Report();
  EXPECT_EQ(j["outcome"], "grasp_not_certified");
  EXPECT_FALSE(j["grasp"]["closed"].get<bool>());
  EXPECT_GE(j["min_clearance_m"].get<double>(), 0.028);
}

// The grasp's plan is checked again, while it is flown, against what the
// grasp map finds in space it had seen free: a ring (6.5 cm about the cup,
// 2.5 cm from it, as tall as the cup) appears 1 s into the grasp, in the
// fingers' way. The camera is pitched 70 degrees down (the bundled one looks
// ahead, and from the staging state sees nothing near the cup), and the
// flight starts at the staging state. The grasp brakes along its path, is
// planned again from its stop on the map with the ring and refused (its
// attempts run out), the gripper never closes, the flight ends
// grasp_not_certified (exit 1), and the clearance against the world with
// the ring is kept, by quadhand-explore's verdict and by
// quadhand-flightcheck's. Without the check the fingers pass 7 mm from the
// ring (exit 6, clearance lost).
TEST_F(ExploreTest, BrakesTheGraspForWhatAppearsInItsWay) {
  std::vector<Vec3> world = CupOnCubeWorld();
  const std::string task = WriteGraspTask(world, "grasp", {"position: [-1.994932877, 0.0, 1.237928495]",
                                                           "joints: [0.6, 0.9707963268, 0.0]"});
  for (double z = 0.5; z <= 0.63 + 1e-9; z += 0.004) {
    const int around = static_cast<int>(std::round(2.0 * M_PI * 0.065 / 0.004));
    for (int k = 0; k < around; ++k) {
      const double a = 2.0 * M_PI * k / around;
      world.emplace_back(-2.2 + 0.065 * std::cos(a), 0.065 * std::sin(a), z);
    }
  }
  const std::string with_ring = WriteGraspTask(world, "ring", {"position: [-1.994932877, 0.0, 1.237928495]",
                                                               "joints: [0.6, 0.9707963268, 0.0]"});
  // The camera's x, y, z (right, down, ahead) in the base: (0, -1, 0),
  // (-sin 70, 0, -cos 70), (cos 70, 0, -sin 70).
  const double pitch = 70.0 * M_PI / 180.0;
  Mat3 axes;
  axes << 0.0, -std::sin(pitch), std::cos(pitch),  //
      -1.0, 0.0, 0.0,                               //
      0.0, -std::cos(pitch), -std::sin(pitch);
  const Quat mount(axes);
  const std::string sim = WriteSimConfig(
      {"splat_spacing_factor: 0.75",
       core::Format("mount: {position: [0.1, 0, 0], orientation: [%.12f, %.12f, %.12f, %.12f]}", mount.w(), mount.x(),
                    mount.y(), mount.z())});
  const auto r = Explore(task, "--resolution 0.05 --tracking-margin 0 --window 6,6,3 --start-free-radius 0.6 "
                               "--sim-config " + sim + " --appear " + with_ring + " --appear-at 1.0");
  EXPECT_EQ(r.exit_code, 1) << r.out << r.err;
  const nlohmann::json j = Report();
  EXPECT_EQ(j["outcome"], "grasp_not_certified");
  EXPECT_FALSE(j["grasp"]["closed"].get<bool>());
  const nlohmann::json& attempts = j["grasp"]["attempts"];
  ASSERT_EQ(attempts.size(), 6u);
  EXPECT_TRUE(attempts[0]["certified"].get<bool>());
  EXPECT_LT(attempts[0]["t"].get<double>(), 1.0);
  for (size_t k = 1; k < attempts.size(); ++k) {
    EXPECT_FALSE(attempts[k]["certified"].get<bool>()) << k;
    EXPECT_GT(attempts[k]["t"].get<double>(), 1.0) << k;
  }
  ASSERT_EQ(j["invalidations"].size(), 1u);
  const nlohmann::json& braked = j["invalidations"][0];
  EXPECT_TRUE(braked["grasp_plan"].get<bool>());
  EXPECT_TRUE(braked["flown_plan"].get<bool>());
  EXPECT_GT(braked["stop_margin_s"].get<double>(), 0.0);
  EXPECT_TRUE(j["kept_clearance"].get<bool>());
  EXPECT_GE(j["min_clearance_m"].get<double>(), 0.034);
  const auto check = Flightcheck(with_ring);
  EXPECT_EQ(check.exit_code, 0) << check.out << check.err;
  EXPECT_NE(check.out.find("0 gripper events"), std::string::npos) << check.out;
}

TEST_F(ExploreTest, BadInputIsOneLineAndExitTwoWithNoOutput) {
  const std::string task = WriteTask(Posts(), Vec3(8.0, 0.0, 1.2));
  const std::string flown = (dir_ / "flown.csv").string();
  struct Case {
    std::string args, expect;
  };
  const std::string empty = (dir_ / "empty.pcd").string();
  ASSERT_TRUE(scene::WritePcd(empty, {}).ok());
  const std::string mission = (dir_ / "mission.yaml").string();
  std::ofstream(mission) << testing::WindowCupMissionText("");
  std::string hold_text = testing::ReadAll(task);
  const size_t goal_at = hold_text.find("goal: ");
  ASSERT_NE(goal_at, std::string::npos);
  const size_t goal_end = hold_text.find('\n', goal_at);
  ASSERT_NE(goal_end, std::string::npos);
  hold_text.insert(goal_end + 1, "  - hold: {duration: 1.0}\n");
  hold_text.replace(goal_at, 6, "mission:\n  - reach: ");
  const std::string hold_mission = (dir_ / "hold.yaml").string();
  std::ofstream(hold_mission) << hold_text;
  const std::string tool_task = (dir_ / "tool.yaml").string();
  std::ofstream(tool_task) << testing::WindowCupTaskText({});
  for (const Case& c : std::vector<Case>{
           {(dir_ / "missing.yaml").string() + " --out " + flown, "missing.yaml"},
           {task + " --out " + flown + " --sensor sonar", "--sensor"},
           {task + " --out " + flown + " --replan-period 0", "replan_period"},
           {task + " --out " + flown + " --resolution nan", "resolution"},
           {task + " --out " + flown + " --world " + empty, "empty.pcd"},
           {task + " --out " + task, "input"},
           {mission + " --out " + flown, "mission step 1 (reach): a tool pose is not yet"},
           {hold_mission + " --out " + flown, "mission step 2 (hold) is not yet"},
           {tool_task + " --out " + flown, "a tool pose is not yet"},
           {task + " --out " + flown + " --window 0,1,1", "window_half_extent"},
           {task + " --out " + flown + " --window 1,1", "--window"},
           {task + " --out " + flown + " --silence 3-1", "--silence"},
           {task + " --out " + flown + " --bad-frames 1.5", "bad-frame probability"},
           {task + " --out " + flown + " --sensor-timeout 0", "sensor_timeout"},
           {task + " --out " + flown + " --appear " + (dir_ / "none.pcd").string(), "none.pcd"},
           {task + " --out " + flown + " --appear " + empty, "empty.pcd"},
           {task + " --out " + flown + " --appear-at -1", "--appear-at"},
       }) {
    const auto r = RunCommand(kExplore + " " + c.args + " --quiet");
    EXPECT_EQ(r.exit_code, 2) << c.args << "\n" << r.out << r.err;
    EXPECT_NE(r.err.find(c.expect), std::string::npos) << c.args << "\n" << r.err;
    EXPECT_EQ(testing::CountLines(r.err), 1) << c.args << "\n" << r.err;
    EXPECT_FALSE(fs::exists(flown)) << c.args;
  }
  const auto help = RunCommand(kExplore + " --help");
  EXPECT_EQ(help.exit_code, 0);
  for (const char* option : {"--out", "--world", "--sensor", "--report", "--replan-period", "--horizon"}) {
    EXPECT_NE(help.out.find(option), std::string::npos) << option;
  }
}

}  // namespace
}  // namespace quadhand

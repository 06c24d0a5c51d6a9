// Task cautions (planner/task.h): valid tasks that may not plan as meant.
#include "quadhand/planner/task.h"

#include <gtest/gtest.h>

#include <string>

namespace quadhand::planner {
namespace {

// A task whose scene is two scans with the given voxel leaves (0: none).
Task TaskWithVoxels(double first, double second, double safety_distance) {
  std::string text = "robot: r.urdf\nsdf_dir: sdf\nscene:\n  - file: a.pcd\n";
  if (first > 0) text += "    voxel: " + std::to_string(first) + "\n";
  text += "  - file: b.ply\n";
  if (second > 0) text += "    voxel: " + std::to_string(second) + "\n";
  text += "start: {position: [0, 0, 1], yaw: 0, joints: []}\ngoal: {position: [1, 0, 1], yaw: 0, joints: []}\n";
  text += "safety_distance: " + std::to_string(safety_distance) + "\n";
  auto task = ParseTaskText(text, "task.yaml", "/base", TaskSources{});
  EXPECT_TRUE(task.ok()) << task.status().message();
  return task.ok() ? *task : Task{};
}

TEST(TaskCautionsTest, AVoxelLeafCoarserThanTheSafetyDistanceIsNamed) {
  EXPECT_TRUE(TaskCautions(TaskWithVoxels(0.0, 0.0, 0.03)).empty());
  EXPECT_TRUE(TaskCautions(TaskWithVoxels(0.01, 0.03, 0.03)).empty());

  const std::vector<std::string> coarse = TaskCautions(TaskWithVoxels(0.01, 0.05, 0.03));
  ASSERT_EQ(coarse.size(), 1u);
  EXPECT_NE(coarse[0].find("task.yaml: scene[1] (/base/b.ply): voxel leaf 0.05 m is coarser than safety_distance "
                           "0.03 m"),
            std::string::npos)
      << coarse[0];

  // A leaf in millimetres by mistake, on both scans.
  EXPECT_EQ(TaskCautions(TaskWithVoxels(10.0, 1e300, 0.03)).size(), 2u);
}

}  // namespace
}  // namespace quadhand::planner

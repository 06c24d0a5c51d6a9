// A tool goal's moving target as the task file gives it (goal.tool.motion,
// contracts.md version 0.3, docs/moving_targets.md): its motion
// (traj/target_motion.h), the scene points that move with it and the speed
// the tool may have relative to it at the grasp.
#pragma once

#include <optional>
#include <string>

#include "quadhand/core/types.h"
#include "quadhand/traj/target_motion.h"

namespace quadhand::planner {

using traj::ParseTargetPath;
using traj::TargetMotion;
using traj::TargetPathSample;

// An axis-aligned box.
struct TargetBox {
  Vec3 min = Vec3::Zero();
  Vec3 max = Vec3::Zero();
  bool Contains(const Vec3& x) const { return (x.array() >= min.array()).all() && (x.array() <= max.array()).all(); }
};

// The target of a tool goal in motion: how it moves, which scene points
// move with it, and how fast the tool may move relative to it at the grasp.
struct MovingTarget {
  TargetMotion motion;
  std::string path_file;                  // the file of a sampled path, for messages ("" for constant motion)
  std::optional<TargetBox> moving_box;    // world box at t = 0: scene points inside it move with the target
  std::optional<double> max_relative_speed;  // m/s between tool and target at the grasp
};

}  // namespace quadhand::planner

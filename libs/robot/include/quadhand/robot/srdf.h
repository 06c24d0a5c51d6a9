// The collision pairs a robot's SRDF (MoveIt's Semantic Robot Description
// Format) disables: its <disable_collisions link1="..." link2="..."/>
// elements. Everything else in an SRDF (groups, end effectors, virtual
// joints, named states) is read by MoveIt, not here, and ignored.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "quadhand/core/status.h"
#include "quadhand/robot/robot_model.h"

namespace quadhand::robot {

// Robot link indices (first < second) of every <disable_collisions> of the
// SRDF at `path`. Errors name the file: unreadable, malformed XML, a root
// other than <robot>, an element without both links, or a link the robot
// does not have (an SRDF written for another URDF).
core::Result<std::vector<std::pair<int, int>>> LoadSrdfDisabledPairs(const std::string& path,
                                                                     const RobotModel& robot);

}  // namespace quadhand::robot

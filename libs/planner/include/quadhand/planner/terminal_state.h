// Collision-free inverse kinematics for a goal given only as a tool pose
// (the paper lists this as future work): find a hovering whole-body state
// (base position, yaw, joints) that puts the tool frame at the goal pose,
// keeps every link the collision threshold away from the scene and the
// joints inside their limits; with an insertion, the state backed off by the
// insertion length must be collision-free too. Several seeded restarts; the
// first state that passes the exact checks wins.
#pragma once

#include "quadhand/core/status.h"
#include "quadhand/env/collision_model.h"
#include <memory>

#include "quadhand/opt/objective.h"
#include "quadhand/opt/solver.h"
#include "quadhand/planner/post_check.h"
#include "quadhand/planner/task.h"

namespace quadhand::planner {

struct TerminalStateOptions {
  int restarts = 24;                   // seeded initial guesses tried at most
  unsigned seed = 0;                   // of the initial guesses
  double position_tolerance = 0.002;   // tool position error accepted, metres
  double angle_tolerance = 0.01;       // tool rotation error accepted, radians
  double collision_margin = 0.0;       // penalised below safety distance + margin (the goal itself may sit at the safety distance: fingers around a cup)
  // Metres below the safety distance a found state may be, as the
  // post-check accepts a plan (Plan() sets it to post_check.clearance_tolerance:
  // a goal the post-check would accept is not refused here).
  double clearance_tolerance = 0.0;
  double joint_limit_margin = 0.05;    // rad kept from every joint limit
  double weight_position = 1e4;        // per m^2
  double weight_rotation = 1e3;        // per unit of d_R = (3 - tr(R_e R_g^T)) / 2
  double weight_collision = 1e3;
  double weight_joint_limits = 1e3;
  // Per unit of 1 - cos(yaw - start yaw): of the states that put the tool
  // at its goal, the one the base need not turn to. A wrist that rolls
  // about the same axis as the yaw (a tool pointing down) leaves the split
  // between them free, and an arbitrary split can leave the vehicle to turn
  // a right angle in transit, through every window on the way.
  double weight_turn = 1.0;
  double collision_mu = 0.01;          // smoothing of the collision penalty, metres
  double joint_limit_mu = 0.02;        // smoothing of the joint-limit penalty, rad

  bool IsValid(std::string* why) const;
};

struct TerminalStateResult {
  BoundaryState state;           // at rest; joint_rates zero
  double position_error = 0.0;   // tool, metres
  double angle_error = 0.0;      // tool, radians
  double clearance = 0.0;        // exact, metres (the smaller of goal and backed-off states)
  int restarts_used = 0;
  double seconds = 0.0;
};

// `tool_link` is the robot link of the tool frame; `collision` is the model
// optimised against, `exact` the one that judges the clearance (the exact
// link meshes: env::ExactMeshModel, or a scene at one time made of them,
// moving_scene.h). Infeasible (with the best errors found) when no restart
// passes; InvalidArgument for bad options.
core::Result<TerminalStateResult> FindTerminalState(const robot::RobotModel& robot,
                                                    const env::CollisionModel& collision,
                                                    const env::CollisionModel& exact, const Task& task,
                                                    const ToolGoal& tool, int tool_link,
                                                    const TerminalStateOptions& options,
                                                    const opt::Solver& solver);

// The objective FindTerminalState minimises, over x = [base position (3),
// yaw, joints (n)] of a hovering robot: weighted squared tool position error,
// rotation distance to the goal orientation, and the trajectory's collision
// and joint-limit cost terms (cost_term.h) at the goal state (collision also
// backed off along the insertion). Exposed
// for gradient tests; `robot` and `collision` must outlive it (task and tool are copied).
std::unique_ptr<opt::Objective> MakeTerminalStateObjective(const robot::RobotModel& robot,
                                                           const env::CollisionModel& collision,
                                                           const Task& task, const ToolGoal& tool,
                                                           int tool_link, const TerminalStateOptions& options);

}  // namespace quadhand::planner

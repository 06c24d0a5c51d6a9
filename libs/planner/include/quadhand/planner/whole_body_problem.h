// The whole-body trajectory optimisation problem of the paper (Sec. VI) as an
// opt::Objective:
//
//   min over waypoints q and durations T:
//     J_s + rho * T + sum over samples of  w_k * lambda . [J_c, J_e, J_v, J_a,
//                                          J_yawrate, J_jointrate, J_omega_xy, J_jointlimit]
//
// as a chain of differentiable layers (forward, then backward in reverse):
//   tau --time map--> T --MINCO s=4 (position), s=2 (yaw + joints)--> samples
//   --flatness (Hopf)--> attitude, thrust, body rate --forward kinematics-->
//   link poses --CollisionModel / insertion / limit penalties--> cost.
// Samples sit at fixed fractions k/K of each piece with trapezoidal weights
// w_k = T_i / K (halved at both ends; K may differ on the insertion piece);
// both parts of the duration gradient (moving sample times and the
// quadrature step) are included.
//
// Variables x = [tau (N); position waypoints (3 x (N-1), column-major);
//                yaw + joint waypoints ((1 + n) x (N-1), column-major)],
// except that a waypoint held in a ball (SetWaypointBalls: a mission's via)
// has, in place of its position, a free v mapped onto the ball.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "quadhand/core/status.h"
#include "quadhand/core/types.h"
#include "quadhand/env/collision_model.h"
#include "quadhand/opt/objective.h"
#include "quadhand/robot/robot_model.h"
#include "quadhand/traj/flatness.h"
#include "quadhand/traj/minco.h"

namespace quadhand::env {
class SelfCollisionModel;  // env/self_collision.h
}  // namespace quadhand::env

namespace quadhand::planner {

class CostTerm;
struct MovingScene;  // moving_scene.h

// A whole-body boundary state: flat outputs and their derivatives.
struct BoundaryState {
  Vec3 position = Vec3::Zero();
  Vec3 velocity = Vec3::Zero();
  Vec3 acceleration = Vec3::Zero();
  Vec3 jerk = Vec3::Zero();
  double yaw = 0.0;  // Hopf yaw (traj/flatness.h), rad
  double yaw_rate = 0.0;
  VecX joints;       // actuated joints, URDF order
  VecX joint_rates;  // empty means zero
};

// The base pose of the robot hovering (level) at `position` with yaw `yaw`:
// where a state at rest puts the base.
inline Pose HoverPose(const Vec3& position, double yaw) {
  return MakePose(position, Eigen::AngleAxisd(yaw, Vec3::UnitZ()).toRotationMatrix());
}

struct Limits {
  double v_max = 2.0;             // m/s
  double a_max = 4.0;             // m/s^2
  double yaw_rate_max = 1.5;      // rad/s
  double body_rate_xy_max = 3.0;  // rad/s
  VecX joint_rate_max;            // rad/s per actuated joint
  VecX joint_lower, joint_upper;  // rad (or m), per actuated joint
};

// Straight-line approach of the tool frame over the last trajectory piece.
struct InsertionGoal {
  bool enabled = false;
  int tool_link = -1;                     // robot link index of the tool frame
  Vec3 tool_position = Vec3::Zero();      // goal position of the tool, world
  Quat tool_orientation = Quat::Identity();
  Vec3 direction = -Vec3::UnitZ();        // unit approach direction, world
  double length = 0.1;                    // metres of straight approach before the goal
  // The approach began before this trajectory (a replan partway down the
  // line to a moving target, replan.h): the tool need not back off the
  // length first, and stays on the line from the first sample; every piece
  // is on the line.
  bool begun = false;
};

struct WholeBodyCostOptions {
  int samples_per_piece = 16;  // K: samples at k/K, k = 0..K
  // K of the insertion piece (when the insertion is enabled); 0: samples_per_piece.
  // The robot moves slowly there (0.12 m in about a second), so 8 intervals
  // still sample it every 1.5 cm, and that piece is the costly one: the
  // gripper's collision queries see the whole target object (half of the
  // collision time of an evaluation on the benchmark with 16).
  int insertion_samples = 8;
  // Workers evaluating the samples, piece by piece (0: one per core, at
  // most one per piece). The cost and its gradient do not depend on it: each
  // piece is summed on its own and the pieces in order. Fixed when the
  // problem is created (SetOptions keeps the workers).
  int threads = 0;
  double time_weight = 20.0;   // rho, per second of total duration
  double energy_weight_position = 1.0;  // on integral ||snap||^2
  double energy_weight_aux = 1.0;       // on integral ||(yaw, joints) accel||^2
  // lambda of each penalty (per second of trajectory: samples are integrated).
  double weight_collision = 1e5;
  double weight_insertion = 1e5;
  double weight_velocity = 1e4;
  double weight_acceleration = 1e4;
  double weight_yaw_rate = 1e4;
  double weight_joint_rate = 1e4;
  double weight_body_rate = 1e4;
  double weight_joint_limits = 1e5;
  double weight_self_collision = 1e5;
  // Penalties start at limit_fraction of each rate limit and joint_limit_margin
  // inside each joint limit, so that the soft penalties leave the post-check's
  // hard limits intact.
  double limit_fraction = 0.97;
  double joint_limit_margin = 0.02;  // rad
  // Collision: penalise distances below `collision_threshold` (the safety
  // distance plus a margin), smoothed over `collision_mu`.
  double collision_threshold = 0.04;
  double collision_mu = 0.01;
  // Self-collision (env/self_collision.h): pairs of robot links closer than
  // `self_collision_threshold` (the task's self-safety distance plus a
  // margin), smoothed over `self_collision_mu`.
  double self_collision_threshold = 0.02;
  double self_collision_mu = 0.01;
  // Threshold of the collision penalty on the insertion piece (when the
  // insertion is enabled), for every link; non-positive: collision_threshold.
  // A grasp may be designed with less clearance than collision_threshold
  // (QuadHand's fingers pass the benchmark cup with 35 mm, the planner's
  // threshold is 40 mm), and then the two penalties fight over the final
  // approach; there the robot moves slowly, so the samples are dense and a
  // smaller margin over the safety distance suffices.
  double insertion_collision_threshold = 0.0;
  double feasibility_mu = 0.1;     // smoothing of squared-rate penalties (units^2)
  double joint_limit_mu = 0.02;    // rad
  // Insertion (paper J_e), on the samples of the last piece: tool distance to
  // the insertion line and rotation distance d_R = (3 - tr(R_e R_g^T)) / 2 to
  // the goal orientation, beyond tolerances; plus, at the piece's first
  // sample, how far the tool is short of backing off the full insertion length.
  double insertion_position_tolerance = 0.0;  // d_e,th, metres
  double insertion_rotation_tolerance = 0.0;  // r_e,th
  double insertion_position_weight = 1.0;     // rho_P
  double insertion_rotation_weight = 1.0;     // rho_R
  // Smoothing of the insertion penalty: the post-check's tolerance (1 cm off
  // the line) is still met with room, and a sharper kink makes this the
  // stiffest term of the problem (docs/benchmark.md, "Tuning history").
  double insertion_mu = 0.01;
  double insertion_backoff_margin = 0.02;  // metres beyond the insertion length
  traj::FlatnessOptions flatness;

  bool IsValid(std::string* why) const;
};

// Value of each term at one x (for reports and benchmarks), unweighted:
// energy (already with its energy weights), total duration, and every sampled
// term by name (cost_term.h) integrated over the trajectory; the weighted sum
// is `total`.
struct CostBreakdown {
  double energy = 0, time = 0, total = 0;
  std::vector<std::pair<std::string, double>> terms;  // in evaluation order
  // The value of the term called `name` (0 when there is none).
  double Term(const std::string& name) const;
};

// One instant of a whole-body trajectory.
struct WholeBodySample {
  double t = 0;
  Vec3 position, velocity, acceleration, jerk;
  Quat attitude = Quat::Identity();  // from flatness
  double thrust = 0;                 // m/s^2
  Vec3 body_rate = Vec3::Zero();     // rad/s, body frame
  double yaw = 0, yaw_rate = 0;
  VecX joints, joint_rates;
  Pose BasePose() const { return MakePose(position, attitude.toRotationMatrix()); }
  // The sample as a boundary state (a replan's start on its plan).
  BoundaryState State() const {
    BoundaryState state;
    state.position = position;
    state.velocity = velocity;
    state.acceleration = acceleration;
    state.jerk = jerk;
    state.yaw = yaw;
    state.yaw_rate = yaw_rate;
    state.joints = joints;
    state.joint_rates = joint_rates;
    return state;
  }
};

// The decoded trajectory: both MINCO curves and flatness.
class WholeBodyTrajectory {
 public:
  WholeBodyTrajectory(traj::Minco position, traj::Minco aux, traj::FlatnessOptions flatness);
  double duration() const { return position_.total_duration(); }
  int num_pieces() const { return position_.num_pieces(); }
  // Sample at global time t (clamped to [0, duration()]).
  WholeBodySample Sample(double t) const;
  const traj::Minco& position() const { return position_; }
  const traj::Minco& aux() const { return aux_; }
  const traj::FlatnessOptions& flatness() const { return flatness_; }

 private:
  traj::Minco position_;
  traj::Minco aux_;
  traj::FlatnessOptions flatness_;
};

// The trajectory from the whole state `start` to `end` (position with its
// velocity, acceleration and jerk; yaw and joints with their rates) through
// the inner waypoints (3 x (pieces - 1) and (1 + joints) x (pieces - 1)) in
// `durations`: what a problem makes of its variables, without a problem (a
// guess to read states from, a leg given by its ends). Joint rates left
// empty are zero.
core::Result<WholeBodyTrajectory> TrajectoryThrough(const BoundaryState& start, const BoundaryState& end,
                                                    const MatX& position_waypoints, const MatX& aux_waypoints,
                                                    const VecX& durations, const traj::FlatnessOptions& flatness);

// The pieces of `first`, then those of `second`, in both curves
// (traj::Minco::Joined), with `first`'s flatness: as smooth at the seam as
// the caller made the two agree there.
core::Result<WholeBodyTrajectory> JoinedTrajectory(const WholeBodyTrajectory& first, const WholeBodyTrajectory& second);
// The first `pieces` pieces of both curves (traj::Minco::Prefix).
core::Result<WholeBodyTrajectory> TrajectoryPrefix(const WholeBodyTrajectory& whole, int pieces);


struct SampleScratch;  // one worker's buffers (whole_body_problem.cc)

// An inner position waypoint (0-based, of N - 1) kept within `radius` of
// `center`: the base passes there at a time the durations decide. The
// constraint is exact, not a penalty: the waypoint's three variables are a
// free v in R^3 mapped onto the closed ball by
//   q = center + radius * 2 v / (1 + |v|^2),
// smooth and onto (|v| = 1 is the sphere), so any unconstrained solver keeps
// it. Pack inverts the map; Unpack and the trajectory apply it.
struct WaypointBall {
  int waypoint = 0;
  Vec3 center = Vec3::Zero();
  double radius = 0.0;
};

class WholeBodyProblem final : public opt::Objective {
 public:
  // `robot` and `collision` (and `self_collision`, whose pairs the
  // self-collision term keeps apart when it has a penalty; null: none) must
  // outlive the problem. Checks sizes and options.
  static core::Result<std::unique_ptr<WholeBodyProblem>> Create(
      const robot::RobotModel& robot, const env::CollisionModel& collision, const BoundaryState& start,
      const BoundaryState& goal, const Limits& limits, const InsertionGoal& insertion,
      const WholeBodyCostOptions& options, int num_pieces,
      const env::SelfCollisionModel* self_collision = nullptr);
  ~WholeBodyProblem() override;

  int num_variables() const override;
  int num_pieces() const { return num_pieces_; }
  int num_joints() const { return num_joints_; }

  // x from waypoints (3 x (N-1) and (1+n) x (N-1)) and durations (N, > 0), and back.
  VecX Pack(const MatX& position_waypoints, const MatX& aux_waypoints, const VecX& durations) const;
  void Unpack(const VecX& x, MatX* position_waypoints, MatX* aux_waypoints, VecX* durations) const;

  // Each term at x (unweighted values and the weighted total).
  core::Result<CostBreakdown> Breakdown(const VecX& x) const;
  core::Result<WholeBodyTrajectory> Trajectory(const VecX& x) const;

  // Holds the given waypoints in their balls (replacing any before): each
  // index in range and used once, each radius positive and finite. Call
  // before Pack.
  core::Status SetWaypointBalls(std::vector<WaypointBall> balls);
  const std::vector<WaypointBall>& waypoint_balls() const { return balls_; }

  // A goal that moves with a target (moving_scene.h, docs/moving_targets.md):
  // the goal given to Create is then the state that grasps the target at
  // t = 0, the trajectory ends at MovedState(goal, T) for its own duration
  // T (whose gradient reaches T through the target's motion), the insertion
  // is the target's at t = 0 and moves with it, and the moving points are
  // avoided where they are at each sample's time. Null: nothing moves. The
  // scene must outlive the problem. With MovingScene::goal_moves false
  // only the points move: the goal and the insertion stay where they are.
  core::Status SetMovingScene(const MovingScene* moving);
  const MovingScene* moving_scene() const { return moving_; }

  const WholeBodyCostOptions& options() const { return options_; }
  // Replaces the weights (e.g. raised after a failed post-check); sizes stay.
  core::Status SetOptions(const WholeBodyCostOptions& options);

 protected:
  bool DoEvaluate(const VecX& x, double* cost, VecX* grad) const override;

 private:
  WholeBodyProblem(const robot::RobotModel& robot, const env::CollisionModel& collision);
  bool Generate(const VecX& x) const;
  double Accumulate(CostBreakdown* breakdown, bool with_gradient) const;
  // The samples of one piece, into the piece's own sums and gradient rows.
  void AccumulatePiece(int piece, bool with_gradient, SampleScratch* scratch) const;

  const robot::RobotModel& robot_;
  const env::CollisionModel& collision_;
  const env::SelfCollisionModel* self_collision_ = nullptr;
  BoundaryState start_, goal_;
  Limits limits_;
  InsertionGoal insertion_;
  WholeBodyCostOptions options_;
  std::vector<WaypointBall> balls_;
  const MovingScene* moving_ = nullptr;
  std::vector<std::unique_ptr<CostTerm>> terms_;  // built from options_ (cost_term.h)
  bool needs_kinematics_ = false;
  int num_pieces_ = 0;
  int num_joints_ = 0;

  // Evaluation workspace (Evaluate is const; one caller at a time).
  struct Workspace;
  std::unique_ptr<Workspace> work_;
};

}  // namespace quadhand::planner

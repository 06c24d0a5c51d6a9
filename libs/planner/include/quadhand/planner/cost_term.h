// The sampled terms of the whole-body cost (whole_body_problem.h): each a
// differentiable penalty evaluated at every cost sample of the trajectory,
// with a weight (lambda) in WholeBodyCostOptions and the post-check kinds
// that raise it. The problem computes the per-sample state once (flatness,
// and forward kinematics when a term needs it), asks every term in order,
// and carries the gradients they leave in SampleGradient back through
// flatness and MINCO. docs/extending.md: adding a term.
#pragma once

#include <functional>
#include <memory>
#include <vector>

#include "quadhand/core/types.h"
#include "quadhand/env/collision_model.h"
#include "quadhand/env/self_collision.h"
#include "quadhand/planner/moving_scene.h"
#include "quadhand/planner/plan_status.h"
#include "quadhand/planner/whole_body_problem.h"
#include "quadhand/robot/kinematics.h"
#include "quadhand/robot/robot_model.h"
#include "quadhand/traj/flatness.h"

namespace quadhand::planner {

// One cost sample: sample k of K on `piece`, at time t within the piece.
struct SampleState {
  int piece = 0;
  int k = 0, K = 0;
  double t = 0;
  double time = 0;               // the sample's time from the trajectory's start (a moving target's clock)
  double weight = 0;             // trapezoidal quadrature weight of the sample (s)
  bool insertion_piece = false;  // the last piece of a plan with an insertion
  Vec3 position, velocity, acceleration, jerk;
  double yaw = 0, yaw_rate = 0;
  const VecX* aux_value = nullptr;  // yaw, then the joints
  const VecX* aux_rate = nullptr;   // yaw rate, then the joint rates
  const traj::FlatState* flat = nullptr;
  const robot::KinematicsState* kinematics = nullptr;  // set when a term NeedsKinematics()
};

// The running sums a term adds to at one sample.
struct SampleSums {
  double& breakdown;  // the term's own value over the trajectory: quadrature weight x value, plus point values
  double& sample;     // this sample's lambda x value of integrated costs (the problem integrates it)
  double& total;      // the objective: point costs add lambda x value here directly
};

// Gradients of lambda x value w.r.t. the per-sample state, for integrated
// costs (the problem scales them by the quadrature weight), and `point` for
// point costs (added as they are).
struct SampleGradient {
  Vec3 position = Vec3::Zero(), velocity = Vec3::Zero(), acceleration = Vec3::Zero();
  Vec3 rotation = Vec3::Zero();  // world-frame rotation vector of the base attitude
  VecX aux_value, aux_rate;      // sized 1 + joints
  traj::FlatStateGrad flat;
  env::StateGradient point;
  bool point_active = false;     // a point cost added to `point`
  // Gradients w.r.t. the sample's time itself, with the state held (a term
  // that measures against something moving: docs/moving_targets.md), of
  // the integrated costs and of the point costs.
  double time = 0.0, point_time = 0.0;
  env::StateGradient scratch;    // workspace for link wrenches
};

// What terms are built from; all outlive the terms.
struct CostTermInputs {
  const robot::RobotModel& robot;
  const env::CollisionModel& collision;
  const Limits& limits;
  const InsertionGoal& insertion;  // direction normalised
  const WholeBodyCostOptions& options;
  const env::SelfCollisionModel* self_collision = nullptr;  // null: no self-collision pairs
  // A moving target and the points that move with it; the insertion is
  // then the target's at t = 0. Null: nothing moves.
  const MovingScene* moving = nullptr;
};

class CostTerm {
 public:
  virtual ~CostTerm() = default;
  virtual bool NeedsKinematics() const { return false; }
  // Adds the term at sample `s` to *sums and, when `gradient` is not null,
  // its gradient to *gradient.
  virtual void AddSample(const SampleState& s, SampleSums* sums, SampleGradient* gradient) const = 0;
};

// A term as the problem lists it.
struct CostTermDescriptor {
  const char* name;                          // CostBreakdown key and the report's final_cost key
  double WholeBodyCostOptions::*weight;      // its lambda
  std::vector<CheckKind> raised_by;          // failed checks that raise the weight
  // Null when the term costs nothing in this problem (the insertion of a
  // plan without one): it is skipped, and its breakdown value stays 0.
  std::function<std::unique_ptr<CostTerm>(const CostTermInputs& inputs, double weight)> make;
};

// Every sampled term, in evaluation order (src/cost_terms.cc).
const std::vector<CostTermDescriptor>& CostTermDescriptors();

}  // namespace quadhand::planner

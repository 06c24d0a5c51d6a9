// The built-in sampled cost terms (cost_term.h), one descriptor each; the
// list and its order are in ../cost_terms.cc.
#pragma once

#include "quadhand/planner/cost_term.h"

namespace quadhand::planner {

// Adds an integrated whole-body penalty at sample `s`: `penalty` returns
// the value and, given a (zeroed) state gradient, adds its gradient there;
// the value goes into the sums and lambda x gradient into *gradient.
template <typename Penalty>
void AddWholeBodyPenalty(int num_joints, double weight, const SampleState& s, SampleSums* sums,
                         SampleGradient* gradient, Penalty&& penalty) {
  env::StateGradient* state_gradient = nullptr;
  if (gradient != nullptr) {
    gradient->scratch.SetZero(num_joints);
    state_gradient = &gradient->scratch;
  }
  const double c = penalty(state_gradient);
  sums->breakdown += s.weight * c;
  sums->sample += weight * c;
  if (gradient != nullptr && c > 0.0) {
    gradient->position += weight * state_gradient->position;
    gradient->rotation += weight * state_gradient->rotation;
    gradient->aux_value.tail(num_joints) += weight * state_gradient->joints;
  }
}

// The rate at which a cost changes as time passes with the robot held, when
// what it measures against moves with `motion`: moving the scene by the
// target's motion is moving the link by its inverse, so with `wrench` the
// cost's gradient w.r.t. a rigid motion of link pose `link`,
//   dc/dt = -(force . v(p) + torque . w),
// v(p) the velocity of the target-fixed point at the link's origin and w
// the target's turn rate about world z.
inline double RateAsTheTargetMoves(const TargetMotion& motion, const Pose& link, const env::LinkWrench& wrench,
                                   double time) {
  return -(wrench.force.dot(motion.PointVelocity(link.translation(), time)) +
           wrench.torque.z() * motion.YawRate(time));
}

// The collision penalty's parameters in transit and on the insertion piece
// (WholeBodyCostOptions::insertion_collision_threshold, or the transit one),
// shared by the still and the moving scene's collision terms.
struct CollisionPenalties {
  env::PenaltyParameters transit, insertion;
};
inline CollisionPenalties CollisionPenaltiesOf(const WholeBodyCostOptions& o) {
  return {{o.collision_threshold, o.collision_mu},
          {o.insertion_collision_threshold > 0.0 ? o.insertion_collision_threshold : o.collision_threshold,
           o.collision_mu}};
}

CostTermDescriptor VelocityTerm();      // rate_limit_terms.cc
CostTermDescriptor AccelerationTerm();  // rate_limit_terms.cc
CostTermDescriptor YawRateTerm();       // rate_limit_terms.cc
CostTermDescriptor JointRateTerm();     // rate_limit_terms.cc
CostTermDescriptor BodyRateTerm();      // rate_limit_terms.cc
CostTermDescriptor JointLimitTerm();    // joint_limit_term.cc
CostTermDescriptor CollisionTerm();     // collision_term.cc
CostTermDescriptor MovingCollisionTerm();  // moving_collision_term.cc
CostTermDescriptor InsertionTerm();     // insertion_term.cc
CostTermDescriptor SelfCollisionTerm(); // self_collision_term.cc

}  // namespace quadhand::planner

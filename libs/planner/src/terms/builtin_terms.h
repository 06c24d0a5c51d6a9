// The built-in sampled cost terms (cost_term.h), one descriptor each; the
// list and its order are in ../cost_terms.cc.
#pragma once

#include "quadhand/planner/cost_term.h"

namespace quadhand::planner {

CostTermDescriptor VelocityTerm();      // rate_limit_terms.cc
CostTermDescriptor AccelerationTerm();  // rate_limit_terms.cc
CostTermDescriptor YawRateTerm();       // rate_limit_terms.cc
CostTermDescriptor JointRateTerm();     // rate_limit_terms.cc
CostTermDescriptor BodyRateTerm();      // rate_limit_terms.cc
CostTermDescriptor JointLimitTerm();    // joint_limit_term.cc
CostTermDescriptor CollisionTerm();     // collision_term.cc
CostTermDescriptor InsertionTerm();     // insertion_term.cc
CostTermDescriptor SelfCollisionTerm(); // self_collision_term.cc

}  // namespace quadhand::planner

#include "quadhand/planner/cost_term.h"
#include "terms/builtin_terms.h"

namespace quadhand::planner {

const std::vector<CostTermDescriptor>& CostTermDescriptors() {
  // Evaluation order: the sums of a sample are accumulated in this order.
  static const std::vector<CostTermDescriptor> terms = {
      VelocityTerm(),   AccelerationTerm(), YawRateTerm(),   JointRateTerm(),
      JointLimitTerm(), BodyRateTerm(),     CollisionTerm(), MovingCollisionTerm(), InsertionTerm(), SelfCollisionTerm(),
  };
  return terms;
}

}  // namespace quadhand::planner

// Collision (the paper's J_c): the collision model's whole-body penalty of
// the link poses, with the transit threshold, or on the insertion piece its
// own (WholeBodyCostOptions::insertion_collision_threshold).
#include "terms/builtin_terms.h"

namespace quadhand::planner {
namespace {

class CollisionPenalty final : public CostTerm {
 public:
  CollisionPenalty(const robot::RobotModel& robot, const env::CollisionModel& collision,
                   env::PenaltyParameters transit, env::PenaltyParameters insertion, double weight)
      : robot_(robot), collision_(collision), transit_(transit), insertion_(insertion), weight_(weight) {}

  bool NeedsKinematics() const override { return true; }

  void AddSample(const SampleState& s, SampleSums* sums, SampleGradient* gradient) const override {
    AddWholeBodyPenalty(robot_.num_actuated(), weight_, s, sums, gradient, [&](env::StateGradient* state_gradient) {
      return env::WholeBodyPenalty(robot_, *s.kinematics, collision_, s.insertion_piece ? insertion_ : transit_,
                                   env::QueryContext{s.piece, s.t}, state_gradient);
    });
  }

 private:
  const robot::RobotModel& robot_;
  const env::CollisionModel& collision_;
  env::PenaltyParameters transit_, insertion_;
  double weight_;
};

}  // namespace

CostTermDescriptor CollisionTerm() {
  return {"collision", &WholeBodyCostOptions::weight_collision, {CheckKind::kClearance},
          [](const CostTermInputs& in, double weight) -> std::unique_ptr<CostTerm> {
            const CollisionPenalties penalties = CollisionPenaltiesOf(in.options);
            return std::make_unique<CollisionPenalty>(in.robot, in.collision, penalties.transit, penalties.insertion,
                                                      weight);
          }};
}

}  // namespace quadhand::planner

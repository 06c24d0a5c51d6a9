// Self-collision: pairs of the robot's links kept apart
// (env::SelfCollisionModel::Penalty), both links' motions in the gradient.
// No term without pairs or without their SDFs.
#include "terms/builtin_terms.h"

namespace quadhand::planner {
namespace {

class SelfCollisionPenalty final : public CostTerm {
 public:
  SelfCollisionPenalty(const robot::RobotModel& robot, const env::SelfCollisionModel& model,
                       env::PenaltyParameters parameters, double weight)
      : robot_(robot), model_(model), parameters_(parameters), weight_(weight) {}

  bool NeedsKinematics() const override { return true; }

  void AddSample(const SampleState& s, SampleSums* sums, SampleGradient* gradient) const override {
    AddWholeBodyPenalty(robot_.num_actuated(), weight_, s, sums, gradient, [&](env::StateGradient* state_gradient) {
      return model_.Penalty(robot_, *s.kinematics, parameters_, state_gradient);
    });
  }

 private:
  const robot::RobotModel& robot_;
  const env::SelfCollisionModel& model_;
  env::PenaltyParameters parameters_;
  double weight_;
};

}  // namespace

CostTermDescriptor SelfCollisionTerm() {
  return {"self_collision", &WholeBodyCostOptions::weight_self_collision, {CheckKind::kSelfClearance},
          [](const CostTermInputs& in, double weight) -> std::unique_ptr<CostTerm> {
            if (in.self_collision == nullptr || !in.self_collision->has_penalty()) return nullptr;
            const env::PenaltyParameters parameters{in.options.self_collision_threshold, in.options.self_collision_mu};
            return std::make_unique<SelfCollisionPenalty>(in.robot, *in.self_collision, parameters, weight);
          }};
}

}  // namespace quadhand::planner

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
    const int n = robot_.num_actuated();
    env::StateGradient* link_gradient = nullptr;
    if (gradient != nullptr) {
      gradient->scratch.SetZero(n);
      link_gradient = &gradient->scratch;
    }
    const double c = model_.Penalty(robot_, *s.kinematics, parameters_, link_gradient);
    sums->breakdown += s.weight * c;
    sums->sample += weight_ * c;
    if (gradient != nullptr && c > 0.0) {
      gradient->position += weight_ * link_gradient->position;
      gradient->rotation += weight_ * link_gradient->rotation;
      gradient->aux_value.tail(n) += weight_ * link_gradient->joints;
    }
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

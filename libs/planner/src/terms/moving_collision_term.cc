// Collision with the scene points that move with a moving target
// (moving_scene.h): the moving points' own model at t = 0, queried with each
// link moved back by the target's displacement at the sample's time; its
// wrench turned back into the world, and the rate at which the penalty
// changes as the points move on (RateAsTheTargetMoves). Thresholds as the
// still scene's collision term.
#include "terms/builtin_terms.h"

namespace quadhand::planner {
namespace {

class MovingCollisionPenalty final : public CostTerm {
 public:
  MovingCollisionPenalty(const robot::RobotModel& robot, const MovingScene& moving, env::PenaltyParameters transit,
                         env::PenaltyParameters insertion, double weight)
      : robot_(robot), moving_(moving), transit_(transit), insertion_(insertion), weight_(weight) {}

  bool NeedsKinematics() const override { return true; }

  void AddSample(const SampleState& s, SampleSums* sums, SampleGradient* gradient) const override {
    const TargetMotion& motion = *moving_.motion;
    const Pose displacement = motion.Displacement(s.time);
    const Pose back = displacement.inverse();
    const env::PenaltyParameters& parameters = s.insertion_piece ? insertion_ : transit_;
    double time_rate = 0.0;
    AddWholeBodyPenalty(robot_.num_actuated(), weight_, s, sums, gradient, [&](env::StateGradient* state_gradient) {
      double total = 0.0;
      for (int link : moving_.collision->links()) {
        const Pose& pose = s.kinematics->link_poses[link];
        env::LinkWrench at_zero;
        const double penalty = moving_.collision->LinkPenalty(link, back * pose, parameters,
                                                              env::QueryContext{s.piece, s.t},
                                                              state_gradient != nullptr ? &at_zero : nullptr);
        total += penalty;
        if (state_gradient == nullptr || penalty <= 0.0) continue;
        env::LinkWrench wrench;
        wrench.force = displacement.linear() * at_zero.force;
        wrench.torque = displacement.linear() * at_zero.torque;
        env::AccumulateLinkWrench(robot_, *s.kinematics, link, wrench, state_gradient);
        time_rate += RateAsTheTargetMoves(motion, pose, wrench, s.time);
      }
      return total;
    });
    if (gradient != nullptr) gradient->time += weight_ * time_rate;
  }

 private:
  const robot::RobotModel& robot_;
  const MovingScene& moving_;
  env::PenaltyParameters transit_, insertion_;
  double weight_;
};

}  // namespace

CostTermDescriptor MovingCollisionTerm() {
  return {"moving_collision", &WholeBodyCostOptions::weight_collision, {CheckKind::kClearance},
          [](const CostTermInputs& in, double weight) -> std::unique_ptr<CostTerm> {
            if (in.moving == nullptr || in.moving->collision == nullptr) return nullptr;  // nothing moves
            const CollisionPenalties penalties = CollisionPenaltiesOf(in.options);
            return std::make_unique<MovingCollisionPenalty>(in.robot, *in.moving, penalties.transit,
                                                            penalties.insertion, weight);
          }};
}

}  // namespace quadhand::planner

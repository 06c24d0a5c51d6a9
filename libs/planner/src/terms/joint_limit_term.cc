// Penalty on joints beyond their limits less a margin: SmoothedL1 of the
// excess above (upper - margin) plus of the excess below (lower + margin).
#include "quadhand/opt/penalty.h"
#include "terms/builtin_terms.h"

namespace quadhand::planner {
namespace {

class JointLimitPenalty final : public CostTerm {
 public:
  JointLimitPenalty(VecX lower, VecX upper, double mu, double weight)
      : lower_(std::move(lower)), upper_(std::move(upper)), mu_(mu), weight_(weight) {}

  void AddSample(const SampleState& s, SampleSums* sums, SampleGradient* gradient) const override {
    for (int q = 0; q < lower_.size(); ++q) {
      const double angle = (*s.aux_value)[1 + q];
      double slope_low = 0, slope_high = 0;
      const double c = opt::SmoothedL1(angle - upper_[q], mu_, &slope_high) +
                       opt::SmoothedL1(lower_[q] - angle, mu_, &slope_low);
      sums->breakdown += s.weight * c;
      sums->sample += weight_ * c;
      if (gradient != nullptr) gradient->aux_value[1 + q] += weight_ * (slope_high - slope_low);
    }
  }

 private:
  VecX lower_, upper_;  // where the penalty starts: lower + margin, upper - margin
  double mu_, weight_;
};

}  // namespace

CostTermDescriptor JointLimitTerm() {
  return {"joint_limits", &WholeBodyCostOptions::weight_joint_limits, {CheckKind::kJointLimits},
          [](const CostTermInputs& in, double weight) -> std::unique_ptr<CostTerm> {
            const WholeBodyCostOptions& o = in.options;
            const VecX lower = in.limits.joint_lower.array() + o.joint_limit_margin;
            const VecX upper = in.limits.joint_upper.array() - o.joint_limit_margin;
            return std::make_unique<JointLimitPenalty>(lower, upper, o.joint_limit_mu, weight);
          }};
}

}  // namespace quadhand::planner

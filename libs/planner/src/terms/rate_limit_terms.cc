// Penalties on rates beyond a fraction of their limits: SmoothedL1(|x|^2 -
// (fraction x max)^2), on speed, acceleration, yaw rate, each joint rate and
// the horizontal body rate (from flatness).
#include "quadhand/opt/penalty.h"
#include "terms/builtin_terms.h"

namespace quadhand::planner {
namespace {

double SquaredRatePenalty(double squared, double max, double mu, double* slope) {
  return opt::SmoothedL1(squared - max * max, mu, slope);
}

// One 3-vector, the velocity (Derivative 1) or the acceleration (2), against one limit.
template <int Derivative>
class VectorRateTerm final : public CostTerm {
 public:
  VectorRateTerm(double max, double mu, double weight) : max_(max), mu_(mu), weight_(weight) {}

  void AddSample(const SampleState& s, SampleSums* sums, SampleGradient* gradient) const override {
    const Vec3& x = Derivative == 1 ? s.velocity : s.acceleration;
    double slope = 0.0;
    const double c = SquaredRatePenalty(x.squaredNorm(), max_, mu_, &slope);
    sums->breakdown += s.weight * c;
    sums->sample += weight_ * c;
    if (gradient != nullptr) {
      (Derivative == 1 ? gradient->velocity : gradient->acceleration) += weight_ * slope * 2.0 * x;
    }
  }

 private:
  double max_, mu_, weight_;
};

class YawRateLimitTerm final : public CostTerm {
 public:
  YawRateLimitTerm(double max, double mu, double weight) : max_(max), mu_(mu), weight_(weight) {}

  void AddSample(const SampleState& s, SampleSums* sums, SampleGradient* gradient) const override {
    double slope = 0.0;
    const double c = SquaredRatePenalty(s.yaw_rate * s.yaw_rate, max_, mu_, &slope);
    sums->breakdown += s.weight * c;
    sums->sample += weight_ * c;
    if (gradient != nullptr) gradient->aux_rate[0] += weight_ * slope * 2.0 * s.yaw_rate;
  }

 private:
  double max_, mu_, weight_;
};

class JointRateLimitTerm final : public CostTerm {
 public:
  JointRateLimitTerm(VecX max, double mu, double weight) : max_(std::move(max)), mu_(mu), weight_(weight) {}

  void AddSample(const SampleState& s, SampleSums* sums, SampleGradient* gradient) const override {
    for (int q = 0; q < max_.size(); ++q) {
      const double rate = (*s.aux_rate)[1 + q];
      double slope = 0.0;
      const double c = SquaredRatePenalty(rate * rate, max_[q], mu_, &slope);
      sums->breakdown += s.weight * c;
      sums->sample += weight_ * c;
      if (gradient != nullptr) gradient->aux_rate[1 + q] += weight_ * slope * 2.0 * rate;
    }
  }

 private:
  VecX max_;  // fraction x limit per joint
  double mu_, weight_;
};

class BodyRateLimitTerm final : public CostTerm {
 public:
  BodyRateLimitTerm(double max, double mu, double weight) : max_(max), mu_(mu), weight_(weight) {}

  void AddSample(const SampleState& s, SampleSums* sums, SampleGradient* gradient) const override {
    double slope = 0.0;
    const double c = SquaredRatePenalty(s.flat->body_rate_xy_sq, max_, mu_, &slope);
    sums->breakdown += s.weight * c;
    sums->sample += weight_ * c;
    if (gradient != nullptr) gradient->flat.body_rate_xy_sq += weight_ * slope;
  }

 private:
  double max_, mu_, weight_;
};

}  // namespace

CostTermDescriptor VelocityTerm() {
  return {"velocity", &WholeBodyCostOptions::weight_velocity, {CheckKind::kVelocity},
          [](const CostTermInputs& in, double weight) -> std::unique_ptr<CostTerm> {
            const WholeBodyCostOptions& o = in.options;
            return std::make_unique<VectorRateTerm<1>>(o.limit_fraction * in.limits.v_max, o.feasibility_mu, weight);
          }};
}

CostTermDescriptor AccelerationTerm() {
  return {"acceleration", &WholeBodyCostOptions::weight_acceleration, {CheckKind::kAcceleration},
          [](const CostTermInputs& in, double weight) -> std::unique_ptr<CostTerm> {
            const WholeBodyCostOptions& o = in.options;
            return std::make_unique<VectorRateTerm<2>>(o.limit_fraction * in.limits.a_max, o.feasibility_mu, weight);
          }};
}

CostTermDescriptor YawRateTerm() {
  return {"yaw_rate", &WholeBodyCostOptions::weight_yaw_rate, {CheckKind::kYawRate},
          [](const CostTermInputs& in, double weight) -> std::unique_ptr<CostTerm> {
            const WholeBodyCostOptions& o = in.options;
            return std::make_unique<YawRateLimitTerm>(o.limit_fraction * in.limits.yaw_rate_max, o.feasibility_mu,
                                                      weight);
          }};
}

CostTermDescriptor JointRateTerm() {
  return {"joint_rate", &WholeBodyCostOptions::weight_joint_rate, {CheckKind::kJointRate},
          [](const CostTermInputs& in, double weight) -> std::unique_ptr<CostTerm> {
            const WholeBodyCostOptions& o = in.options;
            VecX max(in.limits.joint_rate_max.size());
            for (int q = 0; q < max.size(); ++q) max[q] = o.limit_fraction * in.limits.joint_rate_max[q];
            return std::make_unique<JointRateLimitTerm>(std::move(max), o.feasibility_mu, weight);
          }};
}

CostTermDescriptor BodyRateTerm() {
  return {"body_rate", &WholeBodyCostOptions::weight_body_rate, {CheckKind::kBodyRateXY},
          [](const CostTermInputs& in, double weight) -> std::unique_ptr<CostTerm> {
            const WholeBodyCostOptions& o = in.options;
            return std::make_unique<BodyRateLimitTerm>(o.limit_fraction * in.limits.body_rate_xy_max,
                                                       o.feasibility_mu, weight);
          }};
}

}  // namespace quadhand::planner

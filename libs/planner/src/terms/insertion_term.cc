// Insertion (the paper's J_e), on the samples of the insertion piece: the
// tool's distance to the insertion line and its rotation distance
// d_R = (3 - tr(R_e R_g^T)) / 2 to the goal orientation, beyond tolerances;
// plus a point cost at the piece's first sample: how far the tool is short
// of backing off the full insertion length (and a margin) along the line.
#include "quadhand/opt/penalty.h"
#include "terms/builtin_terms.h"
#include "terms/rotation_distance.h"

namespace quadhand::planner {
namespace {

class InsertionPenalty final : public CostTerm {
 public:
  InsertionPenalty(const robot::RobotModel& robot, const InsertionGoal& goal, const WholeBodyCostOptions& o,
                   double weight, const TargetMotion* motion)
      : robot_(robot),
        goal_(goal),
        motion_(motion),
        goal_rotation_(goal.tool_orientation.toRotationMatrix()),
        position_tolerance_(o.insertion_position_tolerance),
        rotation_tolerance_(o.insertion_rotation_tolerance),
        position_weight_(o.insertion_position_weight),
        rotation_weight_(o.insertion_rotation_weight),
        mu_(o.insertion_mu),
        backoff_margin_(o.insertion_backoff_margin),
        weight_(weight) {}

  bool NeedsKinematics() const override { return true; }

  void AddSample(const SampleState& s, SampleSums* sums, SampleGradient* gradient) const override {
    if (!s.insertion_piece) return;
    const int n = robot_.num_actuated();
    const Pose& tool = s.kinematics->link_poses[goal_.tool_link];
    // A moving target carries the line and the goal orientation with it.
    Vec3 goal_position = goal_.tool_position, direction = goal_.direction;
    Mat3 goal_rotation = goal_rotation_;
    if (motion_ != nullptr) {
      const Pose displacement = motion_->Displacement(s.time);
      goal_position = displacement * goal_position;
      direction = displacement.linear() * direction;
      goal_rotation = displacement.linear() * goal_rotation;
    }
    const Vec3 offset = tool.translation() - goal_position;
    const Vec3 across = offset - direction * direction.dot(offset);
    const double off_line = across.norm();
    double slope_position = 0, slope_rotation = 0;
    const double c_position = opt::SmoothedL1(off_line - position_tolerance_, mu_, &slope_position);
    const RotationDistance rotation = RotationDistanceTo(tool.linear(), goal_rotation);
    const double c_rotation = opt::SmoothedL1(rotation.value - rotation_tolerance_, mu_, &slope_rotation);
    const double c = position_weight_ * c_position + rotation_weight_ * c_rotation;
    sums->breakdown += s.weight * c;
    sums->sample += weight_ * c;
    // The insertion piece must start with the tool backed off by the full
    // length (plus a margin) along the line, or part of the approach would
    // escape the penalty. A point cost at the piece's first sample, not
    // integrated: a quadrature weight there would make it negligible.
    if (s.k == 0 && !goal_.begun) {
      double slope_backoff = 0.0;
      const double along = direction.dot(offset);
      const double c_backoff = opt::SmoothedL1(along + goal_.length + backoff_margin_, mu_, &slope_backoff);
      const double scale = weight_ * position_weight_;
      sums->breakdown += c_backoff;
      sums->total += scale * c_backoff;
      if (gradient != nullptr && c_backoff > 0.0) {
        gradient->point_active = true;
        env::LinkWrench wrench;
        wrench.force = scale * slope_backoff * direction;
        env::AccumulateLinkWrench(robot_, *s.kinematics, goal_.tool_link, wrench, &gradient->point);
        if (motion_ != nullptr) gradient->point_time += RateAsTheTargetMoves(*motion_, tool, wrench, s.time);
      }
    }
    if (gradient != nullptr && c > 0.0) {
      env::LinkWrench wrench;
      if (off_line > 0.0) wrench.force = weight_ * position_weight_ * slope_position * across / off_line;
      wrench.torque = weight_ * rotation_weight_ * slope_rotation * rotation.gradient;
      gradient->scratch.SetZero(n);
      env::AccumulateLinkWrench(robot_, *s.kinematics, goal_.tool_link, wrench, &gradient->scratch);
      if (motion_ != nullptr) gradient->time += RateAsTheTargetMoves(*motion_, tool, wrench, s.time);
      gradient->position += gradient->scratch.position;
      gradient->rotation += gradient->scratch.rotation;
      gradient->aux_value.tail(n) += gradient->scratch.joints;
    }
  }

 private:
  const robot::RobotModel& robot_;
  InsertionGoal goal_;  // at t = 0 when the target moves
  const TargetMotion* motion_;  // null: the goal stands still
  Mat3 goal_rotation_;
  double position_tolerance_, rotation_tolerance_, position_weight_, rotation_weight_, mu_, backoff_margin_;
  double weight_;
};

}  // namespace

CostTermDescriptor InsertionTerm() {
  return {"insertion", &WholeBodyCostOptions::weight_insertion, {CheckKind::kInsertion},
          [](const CostTermInputs& in, double weight) -> std::unique_ptr<CostTerm> {
            if (!in.insertion.enabled) return nullptr;  // a plan without an insertion: nothing to cost
            return std::make_unique<InsertionPenalty>(in.robot, in.insertion, in.options, weight,
                                                      in.moving != nullptr && in.moving->goal_moves ? in.moving->motion : nullptr);
          }};
}

}  // namespace quadhand::planner

#include "quadhand/planner/motion_bound.h"

#include <algorithm>
#include <cmath>

#include "quadhand/robot/kinematics.h"

namespace quadhand::planner {
namespace {

constexpr double kInfinity = std::numeric_limits<double>::infinity();

// The derivatives of one piece of a MINCO curve at the middle of a local
// interval: p(mid + delta) = sum_k derivative[k] delta^k / k!, exactly (the
// piece is a polynomial), so |p^(d)(mid + delta)| <= sum_k |derivative[d + k]|
// r^k / k! for |delta| <= r.
class PieceExpansion {
 public:
  PieceExpansion(const traj::Minco& curve, int piece, double mid, double radius)
      : radius_(radius), derivatives_(curve.coeffs_per_piece()) {
    for (int k = 0; k < curve.coeffs_per_piece(); ++k) derivatives_[k] = curve.Evaluate(piece, mid, k);
  }
  const Eigen::VectorXd& AtMid(int d) const { return derivatives_[d]; }
  // Bound of |d-th derivative - its value at mid| over the interval, of
  // coordinate `coordinate` (or of the vector norm when it is -1).
  double Variation(int d, int coordinate = -1) const {
    double bound = 0.0, power = 1.0, factorial = 1.0;
    for (int k = 1; d + k < static_cast<int>(derivatives_.size()); ++k) {
      power *= radius_;
      factorial *= k;
      const Eigen::VectorXd& v = derivatives_[d + k];
      bound += (coordinate < 0 ? v.norm() : std::abs(v[coordinate])) * power / factorial;
    }
    return bound;
  }
  double Magnitude(int d, int coordinate = -1) const {
    const Eigen::VectorXd& v = derivatives_[d];
    return (coordinate < 0 ? v.norm() : std::abs(v[coordinate])) + Variation(d, coordinate);
  }

 private:
  double radius_;
  std::vector<Eigen::VectorXd> derivatives_;
};

}  // namespace

RobotMotionBound::RobotMotionBound(const robot::RobotModel& robot, const env::ExactMeshModel& exact)
    : num_coordinates_(robot.num_actuated()) {
  const std::vector<double> reach = robot::LinkOriginReach(robot);
  for (int link : exact.links()) {
    Vec3 box_min, box_max;
    exact.LinkBox(link, &box_min, &box_max);
    // The farthest point of the box from the link origin bounds every point
    // of the geometry.
    const double radius = box_min.cwiseAbs().cwiseMax(box_max.cwiseAbs()).norm();
    LinkLevers levers;
    levers.base = reach[link] + radius;
    levers.joint.assign(num_coordinates_, 0.0);
    for (int j : robot.JointsToLink(link)) {
      const robot::Joint& joint = robot.joint(j);
      if (joint.q_index < 0) continue;  // fixed
      const double multiplier = joint.is_mimic ? std::abs(joint.mimic_multiplier) : 1.0;
      double lever = 1.0;  // prismatic: every point moves with the joint
      if (joint.type != robot::JointType::kPrismatic) {
        // The axis passes through the child's origin; the reach below it is
        // the chain's offsets (and travels) from there to this link.
        lever = std::isfinite(reach[link]) ? reach[link] - reach[joint.child_link] + radius : kInfinity;
      }
      levers.joint[joint.q_index] += multiplier * lever;
    }
    links_.push_back(std::move(levers));
  }
}

PointSpeedBound RobotMotionBound::Over(const WholeBodyTrajectory& trajectory, double t0, double t1) const {
  const traj::Minco& position = trajectory.position();
  const traj::Minco& aux = trajectory.aux();
  const traj::FlatnessOptions& flatness = trajectory.flatness();
  const double duration = trajectory.duration();
  t0 = std::clamp(t0, 0.0, duration);
  t1 = std::clamp(t1, t0, duration);
  PointSpeedBound result{0.0, 0.0};
  double piece_start = 0.0;
  std::vector<double> joint_rate(num_coordinates_);
  for (int piece = 0; piece < position.num_pieces(); ++piece) {
    const double piece_duration = position.durations()[piece];
    const double piece_end = piece + 1 == position.num_pieces() ? duration : piece_start + piece_duration;
    const double begin = std::max(t0, piece_start), end = std::min(t1, piece_end);
    piece_start = piece_end;
    if (begin > end) continue;
    const double mid = 0.5 * (begin + end) - (piece_end - piece_duration);
    const double radius = 0.5 * (end - begin);
    const PieceExpansion base(position, piece, mid, radius);
    const PieceExpansion joints(aux, piece, mid, radius);

    const double speed = base.Magnitude(1);
    const double jerk = base.Magnitude(3);
    Vec3 thrust_vector = base.AtMid(2);
    thrust_vector.z() += flatness.gravity;
    const double thrust_variation = base.Variation(2);
    const double thrust_min = thrust_vector.norm() - thrust_variation;
    if (!(thrust_min > flatness.min_thrust)) return PointSpeedBound{};
    // c = (a_z + g) / thrust, the cosine of the tilt: its smallest value.
    const double vertical_min = thrust_vector.z() - thrust_variation;
    const double cosine_min = std::max(
        -1.0, vertical_min >= 0.0 ? vertical_min / (thrust_vector.norm() + thrust_variation) : vertical_min / thrust_min);
    if (!(1.0 + cosine_min > flatness.inverted_tolerance)) return PointSpeedBound{};
    const double tilt_rate = jerk / thrust_min;
    const double body_rate =
        tilt_rate * (1.0 + std::sqrt((1.0 - cosine_min) / (1.0 + cosine_min))) + joints.Magnitude(1, 0);
    for (int k = 0; k < num_coordinates_; ++k) joint_rate[k] = joints.Magnitude(1, k + 1);

    double fastest = 0.0;
    for (const LinkLevers& link : links_) {
      double v = body_rate * link.base;
      for (int k = 0; k < num_coordinates_; ++k) {
        if (link.joint[k] != 0.0) v += joint_rate[k] * link.joint[k];
      }
      fastest = std::max(fastest, v);
    }
    if (!std::isfinite(fastest)) return PointSpeedBound{};
    result.world = std::max(result.world, speed + fastest);
    // Two points of two links: each moves at most `fastest` besides the base's translation.
    result.relative = std::max(result.relative, 2.0 * fastest);
  }
  return result;
}

}  // namespace quadhand::planner

#include "quadhand/env/collision_model.h"

#include <algorithm>

namespace quadhand::env {

const char* DistanceQualityName(DistanceQuality quality) {
  switch (quality) {
    case DistanceQuality::kExact: return "exact";
    case DistanceQuality::kApproximate: return "approximate";
    case DistanceQuality::kLowerBound: return "lower bound";
  }
  return "unknown";
}

void StateGradient::SetZero(int num_joints) {
  position.setZero();
  rotation.setZero();
  joints.setZero(num_joints);
}

void AccumulateLinkWrench(const robot::RobotModel& robot, const robot::KinematicsState& kinematics,
                          int link, const LinkWrench& wrench, StateGradient* gradient) {
  // The transpose of the link Jacobian (robot/kinematics.h) applied to the
  // wrench, without forming the matrix.
  const Vec3& p_link = kinematics.link_poses[link].translation();
  const Vec3& p_base = kinematics.link_poses[0].translation();
  gradient->position += wrench.force;
  gradient->rotation += wrench.torque + (p_link - p_base).cross(wrench.force);
  for (int j : robot.JointsToLink(link)) {
    const robot::Joint& joint = robot.joint(j);
    if (joint.q_index < 0) continue;
    const Vec3& axis = kinematics.joint_axes[j];
    const double along_axis =
        joint.type == robot::JointType::kPrismatic
            ? axis.dot(wrench.force)
            : axis.dot(wrench.torque + (p_link - kinematics.joint_origins[j]).cross(wrench.force));
    gradient->joints[joint.q_index] += joint.mimic_multiplier * along_axis;
  }
}

double WholeBodyPenalty(const robot::RobotModel& robot, const robot::KinematicsState& kinematics,
                        const CollisionModel& model, const PenaltyParameters& parameters,
                        const QueryContext& context, StateGradient* gradient) {
  double total = 0.0;
  for (int link : model.links()) {
    LinkWrench wrench;
    const double penalty = model.LinkPenalty(link, kinematics.link_poses[link], parameters, context,
                                             gradient != nullptr ? &wrench : nullptr);
    total += penalty;
    if (gradient != nullptr && penalty > 0.0) AccumulateLinkWrench(robot, kinematics, link, wrench, gradient);
  }
  return total;
}

std::vector<int> SlotsOfLinks(const std::vector<int>& links) {
  int max_link = 0;
  for (int link : links) max_link = std::max(max_link, link);
  std::vector<int> slots(max_link + 1, -1);
  for (size_t i = 0; i < links.size(); ++i) slots[links[i]] = static_cast<int>(i);
  return slots;
}

double WholeBodyClearance(const robot::KinematicsState& kinematics, const CollisionModel& model,
                          double search_radius, const QueryContext& context, int* closest_link) {
  double clearance = search_radius;
  for (int link : model.links()) {
    // Only a link closer than the minimum so far matters: searching within
    // that minimum (not below zero: penetration depths are not searched by
    // radius) gives the same result and prunes more.
    const double radius = std::max(clearance, std::min(search_radius, 0.0));
    const double d = model.LinkClearance(link, kinematics.link_poses[link], radius, context);
    if (d < clearance) {
      clearance = d;
      if (closest_link != nullptr) *closest_link = link;
    }
  }
  return clearance;
}

}  // namespace quadhand::env

#include "quadhand/sim/vehicle_model.h"

#include <cmath>

#include "joint_transform.h"
#include "quadhand/robot/link_meshes.h"

namespace quadhand::sim {
namespace {

using core::Status;

// Adds a point-like body (mass, com, inertia about its com, same frame) to `into`.
void Combine(const MassProperties& add, MassProperties* into) {
  const double m = into->mass + add.mass;
  if (m <= 0.0) return;
  const Vec3 com = (into->mass * into->com + add.mass * add.com) / m;
  auto parallel = [&](const MassProperties& b) -> Mat3 {
    const Vec3 d = b.com - com;
    return b.inertia + b.mass * (d.squaredNorm() * Mat3::Identity() - d * d.transpose());
  };
  const Mat3 inertia = parallel(*into) + parallel(add);
  into->mass = m;
  into->com = com;
  into->inertia = inertia;
}

}  // namespace

Mat6 SpatialInertia(const MassProperties& body) {
  const Mat3 C = Skew(body.com);
  Mat6 I;
  I.topLeftCorner<3, 3>() = body.inertia + body.mass * C * C.transpose();
  I.topRightCorner<3, 3>() = body.mass * C;
  I.bottomLeftCorner<3, 3>() = body.mass * C.transpose();
  I.bottomRightCorner<3, 3>() = body.mass * Mat3::Identity();
  return I;
}

core::Result<VehicleModel> VehicleModel::Create(const robot::RobotModel& robot, const SimConfig& config) {
  return Create(robot, config, nullptr);
}

core::Result<VehicleModel> VehicleModel::WithPayload(const PayloadConfig& payload) const {
  SimConfig config = config_;
  config.payload = payload;
  return Create(robot_, config, &drag_areas_);
}

core::Result<VehicleModel> VehicleModel::Create(const robot::RobotModel& robot, const SimConfig& config,
                                                const std::vector<double>* drag_areas) {
  std::string why;
  if (!config.IsValid(&why)) return Status::InvalidArgument("simulator configuration: " + why);
  VehicleModel model(robot, config);
  const int n = robot.num_actuated();

  // Joint couplings: mimic joints follow their source; the PCGC joint may be locked.
  int pcgc_joint = -1;
  if (!config.pcgc_joint.empty() && (config.pcgc_joint_given || robot.JointIndex(config.pcgc_joint) >= 0)) {
    pcgc_joint = robot.JointIndex(config.pcgc_joint);
    if (pcgc_joint < 0) {
      return Status::InvalidArgument("pcgc.joint: the robot has no joint '" + config.pcgc_joint + "'");
    }
    if (!robot.joint(pcgc_joint).is_mimic) {
      return Status::InvalidArgument("pcgc.joint: '" + config.pcgc_joint + "' is not a mimic joint");
    }
  }
  model.has_pcgc_joint_ = pcgc_joint >= 0;
  model.couplings_.resize(robot.num_joints());
  for (int j = 0; j < robot.num_joints(); ++j) {
    const robot::Joint& joint = robot.joint(j);
    JointCoupling& c = model.couplings_[j];
    if (joint.q_index < 0 || (j == pcgc_joint && !config.pcgc)) continue;  // locked at 0
    c.q_index = joint.q_index;
    c.multiplier = joint.is_mimic ? joint.mimic_multiplier : 1.0;
    c.offset = joint.is_mimic ? joint.mimic_offset : 0.0;
  }

  // Bodies: the URDF inertials, the payload on the tool link.
  model.bodies_.resize(robot.num_links());
  for (int i = 0; i < robot.num_links(); ++i) {
    const robot::Link& link = robot.link(i);
    model.bodies_[i] = MassProperties{link.mass, link.center_of_mass, link.inertia};
  }
  if (model.payload_mass() > 0.0) {
    const int carrier = robot.LinkIndex(config.payload.link);
    if (carrier < 0) {
      return Status::InvalidArgument("payload.link: the robot has no link '" + config.payload.link + "' for the payload");
    }
    Combine(MassProperties{model.payload_mass(), config.payload.offset, Mat3::Zero()}, &model.bodies_[carrier]);
  }
  model.spatial_inertias_.resize(robot.num_links());
  model.total_mass_ = 0.0;
  for (int i = 0; i < robot.num_links(); ++i) {
    model.spatial_inertias_[i] = SpatialInertia(model.bodies_[i]);
    model.total_mass_ += model.bodies_[i].mass;
  }
  if (!(model.total_mass_ > 0.0)) return Status::InvalidArgument("the robot has no mass");

  // Rotors in an X: front-left, rear-left, rear-right, front-right.
  const double a = config.rotors.wheelbase / (2.0 * std::sqrt(2.0));
  const double h = config.rotors.height;
  model.rotor_positions_ = {Vec3(a, a, h), Vec3(-a, a, h), Vec3(-a, -a, h), Vec3(a, -a, h)};
  for (int k = 0; k < 4; ++k) {
    const Vec3& r = model.rotor_positions_[k];
    model.allocation_.col(k) = Vec4(1.0, r.y(), -r.x(), model.rotor_spin_[k] * config.rotors.torque_coefficient);
  }

  // Servo limits.
  const VecX urdf_rates = robot.VelocityLimits();
  model.servo_max_rate_ = VecX(n);
  model.servo_max_acceleration_ = VecX(n);
  if (!config.servo.max_rate.empty() && static_cast<int>(config.servo.max_rate.size()) != n) {
    return Status::InvalidArgument("servo.max_rate: expected " + std::to_string(n) + " values (one per actuated joint)");
  }
  if (static_cast<int>(config.servo.max_acceleration.size()) != n) {
    return Status::InvalidArgument("servo.max_acceleration: expected " + std::to_string(n) +
                                   " values (one per actuated joint)");
  }
  for (int k = 0; k < n; ++k) {
    double rate = config.servo.max_rate.empty() ? urdf_rates[k] : config.servo.max_rate[k];
    if (!(rate > 0.0)) rate = 1e9;  // the URDF gives none: unlimited
    model.servo_max_rate_[k] = rate;
    model.servo_max_acceleration_[k] = config.servo.max_acceleration[k];
  }
  if (!config.controller.nominal_joints.empty() && static_cast<int>(config.controller.nominal_joints.size()) != n) {
    return Status::InvalidArgument("controller.nominal_joints: expected " + std::to_string(n) + " values");
  }
  if (!config.faults.IsValid(n, &why)) return Status::InvalidArgument("simulator configuration: " + why);
  // Each arm link's drag area (faults.wind): Cd times the mean face area of
  // its collision geometry's box in its own frame, a frontal area that does
  // not depend on where the wind comes from. The base's is configured.
  // Reused when only the payload changes (the collision meshes are read).
  model.drag_areas_.assign(robot.num_links(), 0.0);
  if (drag_areas != nullptr) model.drag_areas_ = *drag_areas;
  for (int link : config.faults.wind.active() && drag_areas == nullptr ? robot.CollisionLinks() : std::vector<int>{}) {
    if (link == 0) continue;
    auto mesh = robot::LinkCollisionMesh(robot, link);
    if (!mesh.ok() || mesh->vertices.empty()) continue;
    Vec3 lo = Vec3::Constant(1e300), hi = -lo;
    for (const Vec3& v : mesh->vertices) {
      lo = lo.cwiseMin(v);
      hi = hi.cwiseMax(v);
    }
    const Vec3 e = hi - lo;
    model.drag_areas_[link] = config.faults.wind.arm_drag_coefficient * (e.x() * e.y() + e.y() * e.z() + e.z() * e.x()) / 3.0;
  }
  model.joint_lower_ = robot.LowerLimits();
  model.joint_upper_ = robot.UpperLimits();
  return model;
}

std::vector<double> VehicleModel::JointValues(const VecX& q, bool with_offset) const {
  std::vector<double> values(couplings_.size(), 0.0);
  for (size_t j = 0; j < couplings_.size(); ++j) {
    const JointCoupling& c = couplings_[j];
    if (c.q_index < 0) continue;
    values[j] = c.multiplier * q[c.q_index] + (with_offset ? c.offset : 0.0);
  }
  return values;
}

std::vector<Pose> VehicleModel::LinkPosesInBase(const VecX& q) const {
  const std::vector<double> positions = JointValues(q);
  std::vector<Pose> poses(robot_.num_links(), Pose::Identity());
  for (int j = 0; j < robot_.num_joints(); ++j) {
    const robot::Joint& joint = robot_.joint(j);
    poses[joint.child_link] = poses[joint.parent_link] * internal::JointTransform(joint, positions[j]);
  }
  return poses;
}

MassProperties VehicleModel::MassPropertiesAt(const VecX& q) const {
  const std::vector<Pose> poses = LinkPosesInBase(q);
  MassProperties total;
  for (int i = 0; i < robot_.num_links(); ++i) {
    const MassProperties& b = bodies_[i];
    if (b.mass <= 0.0) continue;
    const Mat3& R = poses[i].linear();
    Combine(MassProperties{b.mass, poses[i] * b.com, R * b.inertia * R.transpose()}, &total);
  }
  return total;
}

}  // namespace quadhand::sim

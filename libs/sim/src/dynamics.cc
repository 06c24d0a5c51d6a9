#include "quadhand/sim/dynamics.h"

#include <algorithm>
#include <cassert>
#include <cmath>

#include "joint_transform.h"

namespace quadhand::sim {
namespace {

// Spatial cross products (Featherstone): crm(v) m = v x m, crf(v) f = v x* f.
Mat6 CrossMotion(const Vec6& v) {
  Mat6 X = Mat6::Zero();
  const Mat3 W = Skew(v.head<3>());
  X.topLeftCorner<3, 3>() = W;
  X.bottomLeftCorner<3, 3>() = Skew(v.tail<3>());
  X.bottomRightCorner<3, 3>() = W;
  return X;
}
Mat6 CrossForce(const Vec6& v) { return -CrossMotion(v).transpose(); }

// Motion transform from parent to child coordinates for X_PC = (R, r).
Mat6 MotionTransform(const Pose& X_PC) {
  const Mat3 E = X_PC.linear().transpose();
  Mat6 X = Mat6::Zero();
  X.topLeftCorner<3, 3>() = E;
  X.bottomLeftCorner<3, 3>() = -E * Skew(X_PC.translation());
  X.bottomRightCorner<3, 3>() = E;
  return X;
}

// Per-link joint data of the tree at a configuration.
struct Tree {
  std::vector<Mat6> X;    // parent -> link motion transform (X[0] unused)
  std::vector<Vec6> S;    // motion subspace of the link's parent joint (child frame)
  std::vector<Vec6> v;    // spatial velocity of every link, own frame
  std::vector<Vec6> a;    // spatial acceleration
  std::vector<Vec6> f;    // net force of the link (forward pass), then of its subtree (backward pass)
};

// Forward pass: velocities, accelerations (base spatial acceleration a0,
// possibly offset by -gravity) and each body's Newton-Euler force; then the
// backward pass accumulates subtree forces. `qd`, `qdd` per robot joint.
void NewtonEuler(const VehicleModel& model, const std::vector<double>& q, const std::vector<double>& qd,
                 const std::vector<double>& qdd, const Vec6& v0, const Vec6& a0, Tree* t) {
  const robot::RobotModel& robot = model.robot();
  const int n = robot.num_links();
  t->X.resize(n);
  t->S.resize(n);
  t->v.resize(n);
  t->a.resize(n);
  t->f.resize(n);
  t->v[0] = v0;
  t->a[0] = a0;
  for (int i = 1; i < n; ++i) {
    const int j = robot.link(i).parent_joint;
    const robot::Joint& joint = robot.joint(j);
    const int p = joint.parent_link;
    t->X[i] = MotionTransform(internal::JointTransform(joint, q[j]));
    t->S[i] = model.coupling(j).q_index >= 0 ? internal::MotionSubspace(joint) : Vec6::Zero();
    const Vec6 vJ = t->S[i] * qd[j];
    t->v[i] = t->X[i] * t->v[p] + vJ;
    t->a[i] = t->X[i] * t->a[p] + t->S[i] * qdd[j] + CrossMotion(t->v[i]) * vJ;
  }
  for (int i = 0; i < n; ++i) {
    const Mat6& I = model.spatial_inertia(i);
    t->f[i] = I * t->a[i] + CrossForce(t->v[i]) * (I * t->v[i]);
  }
  for (int i = n - 1; i >= 1; --i) {
    const int p = robot.joint(robot.link(i).parent_joint).parent_link;
    t->f[p] += t->X[i].transpose() * t->f[i];
  }
}

// Composite spatial inertia of the whole tree in the base frame.
Mat6 CompositeInertia(const VehicleModel& model, const Tree& t) {
  const robot::RobotModel& robot = model.robot();
  std::vector<Mat6> Ic(robot.num_links());
  for (int i = 0; i < robot.num_links(); ++i) Ic[i] = model.spatial_inertia(i);
  for (int i = robot.num_links() - 1; i >= 1; --i) {
    const int p = robot.joint(robot.link(i).parent_joint).parent_link;
    Ic[p] += t.X[i].transpose() * Ic[i] * t.X[i];
  }
  return Ic[0];
}

Vec6 Twist(const VehicleState& s) {
  Vec6 v;
  v << s.body_rate, s.attitude.conjugate() * s.velocity;
  return v;
}

// Spatial acceleration that stands for gravity: -a_g in B.
Vec6 MinusGravity(const VehicleModel& model, const VehicleState& s) {
  Vec6 a = Vec6::Zero();
  a.tail<3>() = s.attitude.conjugate() * Vec3(0.0, 0.0, model.gravity());
  return a;
}

Vec6 AsSpatial(const BaseWrench& w) {
  Vec6 f;
  f << w.torque, w.force;
  return f;
}

BaseWrench AsWrench(const Vec6& f) { return BaseWrench{f.tail<3>(), f.head<3>()}; }

Vec4 ClampThrusts(const VehicleModel& model, const Vec4& thrusts) {
  const RotorConfig& r = model.config().rotors;
  return thrusts.cwiseMax(r.min_thrust).cwiseMin(r.max_thrust);
}

}  // namespace

VehicleState VehicleState::AtRest(const VehicleModel& model, const Vec3& position, const VecX& joints) {
  VehicleState s;
  s.position = position;
  s.joints = joints;
  s.joint_rates = VecX::Zero(joints.size());
  // Thrusts that hold the vehicle (total weight, CoG torque) if within limits.
  const MassProperties mp = model.MassPropertiesAt(joints);
  const double weight = mp.mass * model.gravity();
  const Vec3 torque = -mp.com.cross(Vec3(0.0, 0.0, -weight));
  Vec4 wrench(weight, torque.x(), torque.y(), 0.0);
  s.thrusts = ClampThrusts(model, model.allocation().inverse() * wrench);
  return s;
}

VecX ServoAccelerations(const VehicleModel& model, const VecX& q, const VecX& qd, const VecX& q_setpoint,
                        const VecX& qd_setpoint) {
  const ServoConfig& c = model.config().servo;
  const int n = static_cast<int>(q.size());
  VecX qdd(n);
  for (int k = 0; k < n; ++k) {
    const double target = std::clamp(q_setpoint[k], model.joint_lower()[k], model.joint_upper()[k]);
    const double vmax = model.servo_max_rate()[k];
    const double amax = model.servo_max_acceleration()[k];
    const double rate = std::clamp(qd_setpoint[k] + c.position_gain * (target - q[k]), -vmax, vmax);
    qdd[k] = std::clamp((rate - qd[k]) / (c.time_constant + model.config().faults.servo.extra_lag), -amax, amax);
  }
  return qdd;
}

BaseWrench RotorWrench(const VehicleModel& model, const Vec4& thrusts) {
  const Vec4 w = model.allocation() * thrusts;
  return BaseWrench{Vec3(0.0, 0.0, w[0]), Vec3(w[1], w[2], w[3])};
}

void BaseForwardDynamics(const VehicleModel& model, const VehicleState& state, const VecX& qdd,
                         const BaseWrench& external, DynamicsInfo* info) {
  assert(info != nullptr);
  const std::vector<double> q = model.JointValues(state.joints);
  const std::vector<double> qd = model.JointValues(state.joint_rates, false);
  const std::vector<double> qdd_all = model.JointValues(qdd, false);
  const Vec6 v0 = Twist(state);
  const Vec6 minus_g = MinusGravity(model, state);
  Tree tree;
  NewtonEuler(model, q, qd, qdd_all, v0, minus_g, &tree);
  const Mat6 Ic = CompositeInertia(model, tree);
  const Vec6 F = AsSpatial(external);
  const Vec6 a0 = Ic.ldlt().solve(F - tree.f[0]);
  // The base body alone: I0 (a0 - a_g) + v0 x* I0 v0 = F + W_arm.
  const Mat6& I0 = model.spatial_inertia(0);
  info->arm_wrench = AsWrench(I0 * (a0 + minus_g) + CrossForce(v0) * (I0 * v0) - F);
  info->angular_acceleration = a0.head<3>();
  info->acceleration = state.attitude * (a0.tail<3>() + v0.head<3>().cross(v0.tail<3>()));
}

BaseWrench ArmWrenchOnBase(const VehicleModel& model, const VehicleState& state, const VecX& qdd,
                           const Vec3& acceleration, const Vec3& angular_acceleration) {
  const std::vector<double> q = model.JointValues(state.joints);
  const std::vector<double> qd = model.JointValues(state.joint_rates, false);
  const std::vector<double> qdd_all = model.JointValues(qdd, false);
  const Vec6 v0 = Twist(state);
  Vec6 a0;
  a0 << angular_acceleration, state.attitude.conjugate() * acceleration - v0.head<3>().cross(v0.tail<3>());
  Tree tree;
  NewtonEuler(model, q, qd, qdd_all, v0, a0 + MinusGravity(model, state), &tree);
  const Mat6& I0 = model.spatial_inertia(0);
  const Vec6 base_own = I0 * (a0 + MinusGravity(model, state)) + CrossForce(v0) * (I0 * v0);
  return AsWrench(-(tree.f[0] - base_own));
}

VecX PackState(const VehicleState& s) {
  const int n = static_cast<int>(s.joints.size());
  VecX x(17 + 2 * n);
  x.segment<3>(0) = s.position;
  x.segment<4>(3) = Vec4(s.attitude.w(), s.attitude.x(), s.attitude.y(), s.attitude.z());
  x.segment<3>(7) = s.velocity;
  x.segment<3>(10) = s.body_rate;
  x.segment(13, n) = s.joints;
  x.segment(13 + n, n) = s.joint_rates;
  x.segment<4>(13 + 2 * n) = s.thrusts;
  return x;
}

VehicleState UnpackState(const VecX& x, int n) {
  VehicleState s;
  s.position = x.segment<3>(0);
  s.attitude = Quat(x[3], x[4], x[5], x[6]);
  s.velocity = x.segment<3>(7);
  s.body_rate = x.segment<3>(10);
  s.joints = x.segment(13, n);
  s.joint_rates = x.segment(13 + n, n);
  s.thrusts = x.segment<4>(13 + 2 * n);
  return s;
}

BaseWrench WindWrench(const VehicleModel& model, const VehicleState& state, const Vec3& wind) {
  const WindFault& config = model.config().faults.wind;
  const Mat3 R = state.attitude.toRotationMatrix();
  auto drag = [&](double area, const Vec3& body_velocity) -> Vec3 {
    const Vec3 relative = wind - body_velocity;
    return 0.5 * config.air_density * area * relative.norm() * relative;
  };
  BaseWrench wrench;
  wrench.force = R.transpose() * drag(config.base_drag_area, state.velocity);
  const std::vector<double>& areas = model.drag_areas();
  const std::vector<Pose> poses = model.LinkPosesInBase(state.joints);
  const Vec3 omega_world = R * state.body_rate;
  for (size_t link = 1; link < areas.size(); ++link) {
    if (!(areas[link] > 0.0)) continue;
    const Vec3 r_base = poses[link].translation();
    const Vec3 force_base = R.transpose() * drag(areas[link], state.velocity + omega_world.cross(R * r_base));
    wrench.force += force_base;
    wrench.torque += r_base.cross(force_base);
  }
  return wrench;
}

VecX StateDerivative(const VehicleModel& model, const VecX& x, const ControlInput& u, DynamicsInfo* info) {
  const int n = model.num_actuated();
  VehicleState s = UnpackState(x, n);
  // Intermediate RK4 stages carry a slightly non-unit quaternion; the rotation uses the unit one.
  const Quat q_raw = s.attitude;
  s.attitude.normalize();
  DynamicsInfo local;
  DynamicsInfo* out = info ? info : &local;
  out->joint_accelerations = ServoAccelerations(model, s.joints, s.joint_rates, u.joint_setpoints,
                                                u.joint_rate_setpoints);
  // A weak motor (faults.motor) delivers part of the thrust it holds.
  Vec4 delivered = s.thrusts;
  const MotorFault& motor = model.config().faults.motor;
  if (motor.rotor >= 0) delivered[motor.rotor] *= motor.thrust_factor;
  out->rotor_wrench = RotorWrench(model, delivered);
  BaseWrench external = out->rotor_wrench;
  external.force -= model.config().linear_drag.cwiseProduct(s.attitude.conjugate() * s.velocity);
  if (model.config().faults.wind.active()) {
    const BaseWrench wind = WindWrench(model, s, u.wind);
    external.force += wind.force;
    external.torque += wind.torque;
  }
  BaseForwardDynamics(model, s, out->joint_accelerations, external, out);

  VecX dx(x.size());
  dx.segment<3>(0) = s.velocity;
  const Quat dq = q_raw * Quat(0.0, s.body_rate.x(), s.body_rate.y(), s.body_rate.z());
  dx.segment<4>(3) = 0.5 * Vec4(dq.w(), dq.x(), dq.y(), dq.z());
  dx.segment<3>(7) = out->acceleration;
  dx.segment<3>(10) = out->angular_acceleration;
  dx.segment(13, n) = s.joint_rates;
  dx.segment(13 + n, n) = out->joint_accelerations;
  const double tau = model.config().rotors.time_constant;
  dx.segment<4>(13 + 2 * n) =
      tau > 0.0 ? Vec4((ClampThrusts(model, u.thrust_command) - s.thrusts) / tau) : Vec4(Vec4::Zero());
  return dx;
}

VehicleState Rk4Step(const VehicleModel& model, const VehicleState& state, const ControlInput& u, double h) {
  VehicleState start = state;
  if (model.config().rotors.time_constant <= 0.0) start.thrusts = ClampThrusts(model, u.thrust_command);
  const VecX x = PackState(start);
  const VecX k1 = StateDerivative(model, x, u);
  const VecX k2 = StateDerivative(model, x + 0.5 * h * k1, u);
  const VecX k3 = StateDerivative(model, x + 0.5 * h * k2, u);
  const VecX k4 = StateDerivative(model, x + h * k3, u);
  VehicleState next = UnpackState(x + (h / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4), model.num_actuated());
  next.attitude.normalize();
  return next;
}

VehicleMomentum ComputeMomentum(const VehicleModel& model, const VehicleState& state) {
  const robot::RobotModel& robot = model.robot();
  const std::vector<double> q = model.JointValues(state.joints);
  const std::vector<double> qd = model.JointValues(state.joint_rates, false);
  const std::vector<double> zero(q.size(), 0.0);
  Tree tree;
  NewtonEuler(model, q, qd, zero, Twist(state), Vec6::Zero(), &tree);
  const Pose X_WB = MakePose(state.position, state.attitude.toRotationMatrix());
  const std::vector<Pose> poses = model.LinkPosesInBase(state.joints);

  VehicleMomentum m;
  double mass = 0.0;
  std::vector<Vec3> com(robot.num_links()), com_velocity(robot.num_links());
  for (int i = 0; i < robot.num_links(); ++i) {
    const MassProperties& b = model.body(i);
    const Pose X_WL = X_WB * poses[i];
    const Vec3 w = tree.v[i].head<3>(), u = tree.v[i].tail<3>();
    com[i] = X_WL * b.com;
    com_velocity[i] = X_WL.linear() * (u + w.cross(b.com));
    mass += b.mass;
    m.center_of_mass += b.mass * com[i];
    m.linear += b.mass * com_velocity[i];
    m.kinetic_energy += 0.5 * tree.v[i].dot(model.spatial_inertia(i) * tree.v[i]);
    m.potential_energy += b.mass * model.gravity() * com[i].z();
  }
  m.center_of_mass /= mass;
  m.com_velocity = m.linear / mass;
  for (int i = 0; i < robot.num_links(); ++i) {
    const MassProperties& b = model.body(i);
    const Mat3 R = (X_WB * poses[i]).linear();
    m.angular += R * (b.inertia * tree.v[i].head<3>()) +
                 (com[i] - m.center_of_mass).cross(b.mass * (com_velocity[i] - m.com_velocity));
  }
  return m;
}

}  // namespace quadhand::sim

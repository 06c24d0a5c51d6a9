#include "quadhand/traj/flatness.h"

#include <algorithm>
#include <cmath>

namespace quadhand::traj {

namespace {

using Eigen::Vector3d;
using Eigen::Vector4d;

// Attitude and body rate on the Hopf chart at the unit axis z = (a, b, c) with
// one_c = 1 + c > 0 (passed separately to keep its relative precision).
void HopfAttitude(const Vector3d& z, double one_c, const Vector3d& z_dot, double yaw,
                  double yaw_rate, Vector4d* quat, Vector3d* body_rate) {
  const double a = z.x(), b = z.y();
  const double ch = std::cos(0.5 * yaw), sh = std::sin(0.5 * yaw);
  // |q| = 1 exactly for a unit z; normalising removes the rounding of |z|^2 - 1,
  // which the 1 / (2 (1 + c)) factor amplifies near c = -1.
  *quat = Vector4d(one_c * ch, a * sh - b * ch, a * ch + b * sh, one_c * sh);
  quat->normalize();

  const double sy = std::sin(yaw), cy = std::cos(yaw);
  const double h = z_dot.z() / one_c;
  (*body_rate)[0] = sy * z_dot.x() - cy * z_dot.y() - (a * sy - b * cy) * h;
  (*body_rate)[1] = cy * z_dot.x() + sy * z_dot.y() - (a * cy + b * sy) * h;
  (*body_rate)[2] = (b * z_dot.x() - a * z_dot.y()) / one_c + yaw_rate;
}

}  // namespace

const char* FlatnessStatusName(FlatnessStatus status) {
  switch (status) {
    case FlatnessStatus::kOk: return "ok";
    case FlatnessStatus::kFreeFall: return "free fall";
    case FlatnessStatus::kNearInverted: return "near inverted";
  }
  return "unknown";
}

FlatState FlatForward(const Vector3d& /*vel*/, const Vector3d& acc, const Vector3d& jerk,
                      double yaw, double yaw_rate, const FlatnessOptions& options) {
  FlatState st;
  const Vector3d x = acc + options.gravity * Vector3d::UnitZ();
  const double f = x.norm();
  st.thrust = f;
  if (!(f >= options.min_thrust)) {
    st.status = FlatnessStatus::kFreeFall;
    st.z_body = Vector3d::UnitZ();
    st.z_body_dot.setZero();
    st.quat = Vector4d(std::cos(0.5 * yaw), 0.0, 0.0, std::sin(0.5 * yaw));
    st.body_rate = Vector3d(0.0, 0.0, yaw_rate);
    st.body_rate_xy_sq = 0.0;
    return st;
  }
  st.z_body = x / f;
  st.z_body_dot = (jerk - st.z_body * st.z_body.dot(jerk)) / f;
  st.body_rate_xy_sq = st.z_body_dot.squaredNorm();

  Vector3d chart = st.z_body;
  double one_c = 1.0 + chart.z();
  if (!(one_c >= options.inverted_tolerance)) {
    st.status = FlatnessStatus::kNearInverted;
    one_c = options.inverted_tolerance;
    const double r = std::sqrt(one_c * (2.0 - one_c));  // sqrt(1 - c^2)
    const double n = std::hypot(chart.x(), chart.y());
    chart = n > 0.0 ? Vector3d(r * chart.x() / n, r * chart.y() / n, one_c - 1.0)
                    : Vector3d(r, 0.0, one_c - 1.0);
  }
  HopfAttitude(chart, one_c, st.z_body_dot, yaw, yaw_rate, &st.quat, &st.body_rate);
  return st;
}

FlatInputGrad FlatBackward(const Vector3d& /*vel*/, const Vector3d& acc, const Vector3d& jerk,
                           double yaw, double /*yaw_rate*/, const FlatState& st,
                           const FlatStateGrad& grad, const FlatnessOptions& options) {
  FlatInputGrad out;
  const Vector4d& q = st.quat;
  const Vector3d& w = st.body_rate;
  // Paths through psi and psi_dot exist in every case: dq/dpsi = [-q3, q2, -q1, q0] / 2,
  // d omega_x / dpsi = omega_y, d omega_y / dpsi = -omega_x, d omega_z / dpsi_dot = 1.
  out.yaw = 0.5 * (-grad.quat[0] * q[3] + grad.quat[1] * q[2] - grad.quat[2] * q[1] +
                   grad.quat[3] * q[0]);
  out.yaw_rate = grad.body_rate.z();

  const Vector3d x = acc + options.gravity * Vector3d::UnitZ();
  const double f = st.thrust;
  if (st.status == FlatnessStatus::kFreeFall) {
    // The free-fall fallback does not rotate with psi in x/y, so omega_xy has no psi path.
    if (f > 0.0) out.acc = grad.thrust * x / f;
    return out;
  }
  out.yaw += grad.body_rate.x() * w.y() - grad.body_rate.y() * w.x();

  const Vector3d& z = st.z_body;
  const Vector3d& zd = st.z_body_dot;
  Vector3d g_zd = 2.0 * grad.body_rate_xy_sq * zd;
  Vector3d g_z = Vector3d::Zero();
  double g_f = grad.thrust;

  if (st.status == FlatnessStatus::kOk) {
    const double a = z.x(), b = z.y(), c = z.z();
    const double den = 1.0 + c;
    const double sy = std::sin(yaw), cy = std::cos(yaw);
    const double h = zd.z() / den;
    const double gx = grad.body_rate.x(), gy = grad.body_rate.y(), gw = grad.body_rate.z();
    const double ux = a * sy - b * cy;  // coefficient of -h in omega_x
    const double uy = a * cy + b * sy;  // coefficient of -h in omega_y
    g_zd.x() += gx * sy + gy * cy + gw * b / den;
    g_zd.y() += -gx * cy + gy * sy - gw * a / den;
    g_zd.z() += -(gx * ux + gy * uy) / den;
    g_z.x() += -(gx * sy + gy * cy) * h - gw * zd.y() / den;
    g_z.y() += (gx * cy - gy * sy) * h + gw * zd.x() / den;
    g_z.z() += (gx * ux + gy * uy) * h / den - gw * (b * zd.x() - a * zd.y()) / (den * den);

    const double k = std::sqrt(2.0 * den);
    const double ch = std::cos(0.5 * yaw), sh = std::sin(0.5 * yaw);
    const Vector4d& gq = grad.quat;
    g_z.x() += (gq[1] * sh + gq[2] * ch) / k;
    g_z.y() += (-gq[1] * ch + gq[2] * sh) / k;
    g_z.z() += (gq[0] * ch + gq[3] * sh) / k - gq.dot(q) / (k * k);
  }

  // z_dot = (j - z (z.j)) / f.
  const double zj = z.dot(jerk);
  out.jerk = (g_zd - z * z.dot(g_zd)) / f;
  g_z -= (g_zd * zj + z.dot(g_zd) * jerk) / f;
  g_f -= g_zd.dot(zd) / f;
  // z = x / f, f = |x|.
  out.acc = (g_z - z * z.dot(g_z)) / f + g_f * z;
  return out;
}

double HopfYawOf(const Eigen::Quaterniond& attitude) {
  const Eigen::Quaterniond q = attitude.normalized();
  const Eigen::Vector3d z = q * Eigen::Vector3d::UnitZ();
  // The minimal tilt taking e3 to z (the Hopf chart); what is left is the yaw.
  Eigen::Quaterniond tilt(std::max(1.0 + z.z(), 1e-9), -z.y(), z.x(), 0.0);
  tilt.normalize();
  const Eigen::Quaterniond q_yaw = tilt.conjugate() * q;
  return std::remainder(2.0 * std::atan2(q_yaw.z(), q_yaw.w()), 2.0 * M_PI);
}

double HopfYawRateOf(const Eigen::Quaterniond& attitude, const Eigen::Vector3d& body_rate) {
  const Eigen::Matrix3d R = attitude.normalized().toRotationMatrix();
  const Eigen::Vector3d z = R.col(2);
  const Eigen::Vector3d z_dot = R * body_rate.cross(Eigen::Vector3d::UnitZ());
  const double one_c = std::max(1.0 + z.z(), 1e-9);
  return body_rate.z() - (z.y() * z_dot.x() - z.x() * z_dot.y()) / one_c;
}

}  // namespace quadhand::traj

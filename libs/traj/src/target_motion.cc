#include "quadhand/traj/target_motion.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <sstream>

#include "quadhand/core/text.h"

namespace quadhand::traj {
namespace {

// J r: the cross product of world z with r.
Vec3 AboutZ(const Vec3& r) { return Vec3(-r.y(), r.x(), 0.0); }

Mat3 RotationAboutZ(double angle) { return Eigen::AngleAxisd(angle, Vec3::UnitZ()).toRotationMatrix(); }

// The tilt allowed between rows of a sampled path: 0.1 degree.
constexpr double kMaxTilt = 0.1 * M_PI / 180.0;

}  // namespace

TargetMotion TargetMotion::Constant(const Vec3& origin, const Vec3& velocity, const Vec3& acceleration,
                                    double yaw_rate) {
  TargetMotion motion;
  motion.origin_ = origin;
  motion.velocity_ = velocity;
  motion.acceleration_ = acceleration;
  motion.yaw_rate_ = yaw_rate;
  return motion;
}

TargetMotion TargetMotion::Sampled(std::vector<TargetPathSample> path) {
  TargetMotion motion;
  motion.path_ = std::move(path);
  return motion;
}

int TargetMotion::Segment(double t) const {
  const int rows = static_cast<int>(path_.size());
  if (rows < 2) return 0;
  // The last interval that starts at or before t, clamped to the path's.
  const auto after = std::upper_bound(path_.begin(), path_.end(), t,
                                      [](double time, const TargetPathSample& row) { return time < row.t; });
  const int index = static_cast<int>(after - path_.begin()) - 1;
  return std::clamp(index, 0, rows - 2);
}

TargetPathSample TargetMotion::Interpolated(double t) const {
  if (path_.size() == 1) return path_[0];
  const int k = Segment(t);
  const TargetPathSample& a = path_[k];
  const TargetPathSample& b = path_[k + 1];
  const double f = std::clamp((t - a.t) / (b.t - a.t), 0.0, 1.0);
  return TargetPathSample{t, (1.0 - f) * a.position + f * b.position, (1.0 - f) * a.yaw + f * b.yaw};
}

TargetMotion TargetMotion::Shifted(double offset) const {
  TargetMotion shifted = *this;
  shifted.offset_ += offset;
  return shifted;
}

Vec3 TargetMotion::CenterAt(double t) const {
  if (!sampled()) return origin_ + velocity_ * t + 0.5 * acceleration_ * t * t;
  return Interpolated(t).position;
}

double TargetMotion::YawAt(double t) const {
  if (!sampled()) return yaw_rate_ * t;
  return Interpolated(t).yaw - Interpolated(0.0).yaw;
}

double TargetMotion::YawRateAt(double t) const {
  if (!sampled()) return yaw_rate_;
  if (path_.size() < 2 || t < path_.front().t || t >= path_.back().t) return 0.0;
  const int k = Segment(t);
  return (path_[k + 1].yaw - path_[k].yaw) / (path_[k + 1].t - path_[k].t);
}

Pose TargetMotion::DisplacementAt(double t) const {
  const Mat3 rotation = RotationAboutZ(YawAt(t));
  return MakePose(CenterAt(t) - rotation * CenterAt(0.0), rotation);
}

Vec3 TargetMotion::PointVelocityAt(const Vec3& x, double t) const {
  Vec3 center_velocity;
  if (!sampled()) {
    center_velocity = velocity_ + acceleration_ * t;
  } else if (path_.size() < 2 || t < path_.front().t || t >= path_.back().t) {
    center_velocity = Vec3::Zero();
  } else {
    const int k = Segment(t);
    center_velocity = (path_[k + 1].position - path_[k].position) / (path_[k + 1].t - path_[k].t);
  }
  return center_velocity + YawRateAt(t) * AboutZ(x - CenterAt(t));
}

Vec3 TargetMotion::Center(double t) const { return CenterAt(t + offset_); }
double TargetMotion::Yaw(double t) const { return YawAt(t + offset_); }
double TargetMotion::YawRate(double t) const { return YawRateAt(t + offset_); }
Pose TargetMotion::Displacement(double t) const { return DisplacementAt(t + offset_); }
Vec3 TargetMotion::PointVelocity(const Vec3& x, double t) const { return PointVelocityAt(x, t + offset_); }

void TargetMotion::PointDerivatives(const Vec3& x0, double t, Vec3 out[5]) const {
  t += offset_;
  out[0] = DisplacementAt(t) * x0;
  const Vec3 r = out[0] - CenterAt(t);
  const double w = YawRateAt(t);
  const Vec3 center_acceleration = sampled() ? Vec3::Zero() : acceleration_;
  const Vec3 j1 = AboutZ(r), j2 = AboutZ(j1), j3 = AboutZ(j2), j4 = AboutZ(j3);
  out[1] = PointVelocityAt(out[0], t);
  out[2] = center_acceleration + w * w * j2;
  out[3] = w * w * w * j3;
  out[4] = w * w * w * w * j4;
}

double TargetMotion::MaxSpeed(double radius, double horizon) const {
  horizon = std::max(0.0, horizon);
  const double from = offset_, to = offset_ + horizon;
  if (!sampled()) {
    return std::max((velocity_ + acceleration_ * from).norm(), (velocity_ + acceleration_ * to).norm()) +
           std::abs(yaw_rate_) * radius;
  }
  double fastest = 0.0;
  for (size_t k = 0; k + 1 < path_.size(); ++k) {
    if (path_[k].t > to || path_[k + 1].t < from) continue;
    const double dt = path_[k + 1].t - path_[k].t;
    const double speed = (path_[k + 1].position - path_[k].position).norm() / dt +
                         std::abs(path_[k + 1].yaw - path_[k].yaw) / dt * radius;
    fastest = std::max(fastest, speed);
  }
  return fastest;
}

double TargetMotion::MaxYawRate(double horizon) const {
  if (!sampled()) return std::abs(yaw_rate_);
  const double from = offset_, to = offset_ + std::max(0.0, horizon);
  double fastest = 0.0;
  for (size_t k = 0; k + 1 < path_.size(); ++k) {
    if (path_[k].t > to || path_[k + 1].t < from) continue;
    fastest = std::max(fastest, std::abs(path_[k + 1].yaw - path_[k].yaw) / (path_[k + 1].t - path_[k].t));
  }
  return fastest;
}

core::Result<std::vector<TargetPathSample>> ParseTargetPath(const std::string& text, const std::string& source) {
  auto error = [&source](int line, const std::string& problem) {
    return core::Status::InvalidArgument(source + (line > 0 ? ":" + std::to_string(line) : std::string()) + ": " +
                                         problem);
  };
  std::istringstream in(text);
  std::string line;
  int line_number = 0;
  std::vector<std::string> header;
  while (header.empty() && std::getline(in, line)) {
    ++line_number;
    if (!core::Trimmed(line).empty()) header = core::TrimmedFields(core::Trimmed(line));
  }
  if (header.empty()) return error(0, "empty target path (expected a header t,x,y,z,qw,qx,qy,qz and rows)");
  const char* names[] = {"t", "x", "y", "z", "qw", "qx", "qy", "qz"};
  int column[8];
  for (int c = 0; c < 8; ++c) {
    const auto found = std::find(header.begin(), header.end(), names[c]);
    if (found == header.end()) return error(line_number, std::string("missing column '") + names[c] + "'");
    column[c] = static_cast<int>(found - header.begin());
  }
  std::vector<TargetPathSample> path;
  Quat first = Quat::Identity();
  while (std::getline(in, line)) {
    ++line_number;
    const std::string row = core::Trimmed(line);
    if (row.empty()) continue;
    const std::vector<std::string> cells = core::TrimmedFields(row);
    if (cells.size() != header.size()) {
      return error(line_number, "expected " + std::to_string(header.size()) + " values, got " +
                                    std::to_string(cells.size()));
    }
    double v[8];
    for (int c = 0; c < 8; ++c) {
      const std::string& cell = cells[column[c]];
      char* end = nullptr;
      errno = 0;
      v[c] = std::strtod(cell.c_str(), &end);
      if (cell.empty() || end != cell.c_str() + cell.size() || errno == ERANGE || !std::isfinite(v[c])) {
        return error(line_number, std::string("column ") + names[c] + ": expected a finite number, got '" + cell + "'");
      }
    }
    if (!path.empty() && !(v[0] > path.back().t)) {
      return error(line_number, core::Format("time %.9g does not increase (the row before is at %.9g)", v[0],
                                             path.back().t));
    }
    const Quat q(v[4], v[5], v[6], v[7]);
    if (std::abs(q.norm() - 1.0) > 1e-3) {
      return error(line_number, core::Format("the quaternion (qw, qx, qy, qz) is not of unit length (norm %.6f)",
                                             q.norm()));
    }
    TargetPathSample sample;
    sample.t = v[0];
    sample.position = Vec3(v[1], v[2], v[3]);
    const Quat unit = q.normalized();
    if (path.empty()) first = unit;
    const Quat turn = unit * first.conjugate();
    const double tilt = 2.0 * std::asin(std::min(1.0, std::hypot(turn.x(), turn.y())));
    if (tilt > kMaxTilt) {
      return error(line_number, core::Format("the orientation tilts %.3f degrees from the first row's; a target may "
                                             "turn only about the world z axis",
                                             tilt * 180.0 / M_PI));
    }
    const double yaw = 2.0 * std::atan2(turn.z(), turn.w());
    sample.yaw = path.empty() ? 0.0 : path.back().yaw + std::remainder(yaw - path.back().yaw, 2.0 * M_PI);
    path.push_back(sample);
  }
  if (path.size() < 2) return error(0, "a target path needs at least 2 rows");
  return path;
}

}  // namespace quadhand::traj

#include "sampled_checks.h"

#include <cmath>
#include <functional>
#include <string>
#include <utility>

#include "quadhand/core/text.h"

namespace quadhand::planner {
namespace {

using core::Format;

void Add(PostCheckReport* report, CheckKind kind, int joint, std::string name, bool passed, double value, double bound,
         double time, std::string detail) {
  report->checks.push_back({kind, joint, std::move(name), passed, value, bound, time, std::move(detail)});
}

// The worst of one quantity over the samples, and when.
struct Worst {
  double value = -1e300;
  double time = 0.0;
  void Update(double v, double t) {
    if (v > value) {
      value = v;
      time = t;
    }
  }
};

double WrapAngle(double a) { return std::remainder(a, 2.0 * M_PI); }

// A quantity as a fraction of its limit (1 = at the limit), its peak
// accepted up to 1 + limit_tolerance; listed in the report's violations.
class LimitRatio final : public SampledCheck {
 public:
  LimitRatio(CheckKind kind, int joint, std::string name, double tolerance,
             std::function<double(const WholeBodySample&)> ratio)
      : kind_(kind), joint_(joint), name_(std::move(name)), bound_(1.0 + tolerance), ratio_(std::move(ratio)) {}
  void Observe(const CheckedSample& s) override { worst_.Update(ratio_(*s.state), s.t); }
  void Finish(PostCheckReport* report) override {
    report->violations.emplace_back(name_, worst_.value);
    Add(report, kind_, joint_, name_, worst_.value <= bound_, worst_.value, 1.0, worst_.time,
        Format("peak %.3f of the limit (accepted up to %.3f) at t = %.2f s", worst_.value, bound_, worst_.time));
  }

 private:
  CheckKind kind_;
  int joint_;
  std::string name_;
  double bound_;
  std::function<double(const WholeBodySample&)> ratio_;
  Worst worst_;
};

// How far any joint goes beyond its limits.
class JointLimits final : public SampledCheck {
 public:
  explicit JointLimits(const Limits& limits) : limits_(limits) {}
  void Observe(const CheckedSample& s) override {
    for (int q = 0; q < s.state->joints.size(); ++q) {
      excess_.Update(std::max(s.state->joints[q] - limits_.joint_upper[q], limits_.joint_lower[q] - s.state->joints[q]),
                     s.t);
    }
  }
  void Finish(PostCheckReport* report) override {
    Add(report, CheckKind::kJointLimits, -1, "joint_limits", excess_.value <= kAccepted, excess_.value, 0.0,
        excess_.time,
        Format("worst excess %.4f rad beyond a joint limit (accepted up to %.4f) at t = %.2f s", excess_.value,
               kAccepted, excess_.time));
  }

 private:
  static constexpr double kAccepted = 1e-3;  // rad
  const Limits& limits_;
  Worst excess_;
};

// The trajectory starts at the task's start state and ends at rest at the terminal one.
class StartAndEndStates final : public SampledCheck {
 public:
  explicit StartAndEndStates(const CheckInputs& in) : in_(in) {}
  void Finish(PostCheckReport* report) override {
    const PostCheckOptions& options = in_.options;
    const Task& task = in_.task;
    const BoundaryState& terminal = in_.terminal;
    const double duration = in_.trajectory.duration();
    const int n = in_.robot.num_actuated();
    const WholeBodySample first = in_.trajectory.Sample(0.0), last = in_.trajectory.Sample(duration);
    double start_error = (first.position - task.start.position).norm();
    double start_angle = std::abs(WrapAngle(first.yaw - task.start.yaw));
    double end_angle = std::abs(WrapAngle(last.yaw - terminal.yaw));
    start_angle = std::max(start_angle, (first.joints - task.start.joints).cwiseAbs().maxCoeff());
    end_angle = std::max(end_angle, (last.joints - terminal.joints).cwiseAbs().maxCoeff());
    const double end_error = (last.position - terminal.position).norm();
    const VecX terminal_joint_rates = terminal.joint_rates.size() == n ? terminal.joint_rates : VecX::Zero(n);
    const double end_rate =
        std::max({(last.velocity - terminal.velocity).norm(), std::abs(last.yaw_rate - terminal.yaw_rate),
                  (last.joint_rates - terminal_joint_rates).cwiseAbs().maxCoeff()});
    Add(report, CheckKind::kStartState, -1, "start_state",
        start_error <= options.position_tolerance && start_angle <= options.angle_tolerance, start_error,
        options.position_tolerance, 0.0, Format("position error %.4f m, angle error %.4f rad", start_error, start_angle));
    Add(report, CheckKind::kEndState, -1, "end_state",
        end_error <= options.position_tolerance && end_angle <= options.angle_tolerance &&
            end_rate <= options.rate_tolerance,
        end_error, options.position_tolerance, duration,
        Format("position error %.4f m, angle error %.4f rad, residual rate %.4f", end_error, end_angle, end_rate));
  }

 private:
  const CheckInputs& in_;
};

// The tool's final approach: from the last sample where it was at least
// the insertion length back along the line (an approach that began before
// the trajectory: from its first sample), it stays on the line.
class InsertionLine final : public SampledCheck {
 public:
  InsertionLine(const InsertionGoal& insertion, const PostCheckOptions& options)
      : insertion_(insertion), options_(options) {}
  void Observe(const CheckedSample& s) override {
    const Vec3 offset = s.tool - insertion_.tool_position;
    const double along = insertion_.direction.dot(offset);
    track_.emplace_back(along, (offset - along * insertion_.direction).norm());
    times_.push_back(s.t);
  }
  void Finish(PostCheckReport* report) override {
    int approach_start = insertion_.begun && !track_.empty() ? 0 : -1;
    for (int i = static_cast<int>(track_.size()) - 1; i >= 0 && approach_start < 0; --i) {
      if (track_[i].first <= -insertion_.length + 1e-3) {
        approach_start = i;
        break;
      }
    }
    if (approach_start < 0) {
      Add(report, CheckKind::kInsertion, -1, "insertion", false, 0.0, insertion_.length, 0.0,
          Format("the tool never backs off %.3f m along the insertion line (closest approach start %.3f m)",
                 insertion_.length, -track_.front().first));
      return;
    }
    Worst off_line;
    for (size_t i = approach_start; i < track_.size(); ++i) off_line.Update(track_[i].second, times_[i]);
    const double tool_end_error = std::hypot(track_.back().first, track_.back().second);
    Add(report, CheckKind::kInsertion, -1, "insertion",
        off_line.value <= options_.insertion_tolerance && tool_end_error <= options_.position_tolerance,
        off_line.value, options_.insertion_tolerance, off_line.time,
        Format("tool up to %.4f m off the insertion line (accepted %.4f m), ends %.4f m from the goal", off_line.value,
               options_.insertion_tolerance, tool_end_error) +
            Format(", over the approach from t = %.2f s", times_[approach_start]));
  }

 private:
  const InsertionGoal& insertion_;
  const PostCheckOptions& options_;
  std::vector<std::pair<double, double>> track_;  // (along the line, off it) per sample
  std::vector<double> times_;
};

// The base passes each via (Task::vias) within its tolerance, in order:
// the closest approach to a via is sought after the previous via's, from
// the nearest regular sample, refined between its neighbours (golden
// section on the distance, which is smooth and, that close, has one
// minimum).
class ViaPassage final : public SampledCheck {
 public:
  explicit ViaPassage(const CheckInputs& in) : in_(in) {}
  void Observe(const CheckedSample& s) override { track_.emplace_back(s.t, s.state->position); }
  void Finish(PostCheckReport* report) override {
    const std::vector<ViaPoint>& vias = in_.task.vias;
    size_t from = 0;
    bool passed = true;
    double worst_ratio = -1.0;
    CheckResult worst{CheckKind::kVia, -1, CheckKindName(CheckKind::kVia), true, 0.0, 0.0, 0.0, ""};
    for (size_t k = 0; k < vias.size() && !track_.empty(); ++k) {
      const Vec3& point = vias[k].position;
      size_t best = from;
      double best_distance = (track_[from].second - point).norm();
      for (size_t i = from + 1; i < track_.size(); ++i) {
        const double d = (track_[i].second - point).norm();
        if (d < best_distance) {
          best = i;
          best_distance = d;
        }
      }
      auto distance = [&](double t) { return (in_.trajectory.Sample(t).position - point).norm(); };
      double lo = track_[best > from ? best - 1 : best].first;
      double hi = track_[best + 1 < track_.size() ? best + 1 : best].first;
      const double golden = 0.5 * (std::sqrt(5.0) - 1.0);
      for (int iteration = 0; iteration < 40 && hi - lo > 1e-7; ++iteration) {
        const double a = hi - golden * (hi - lo), b = lo + golden * (hi - lo);
        if (distance(a) < distance(b)) {
          hi = b;
        } else {
          lo = a;
        }
      }
      double t = 0.5 * (lo + hi);
      double d = distance(t);
      if (best_distance < d) {  // the refinement never ends farther than the sample it began from
        t = track_[best].first;
        d = best_distance;
      }
      report->via_times.push_back(t);
      const bool ok = d <= vias[k].tolerance;
      passed = passed && ok;
      const double ratio = d / vias[k].tolerance;
      if (ratio > worst_ratio) {
        worst_ratio = ratio;
        worst.value = d;
        worst.bound = vias[k].tolerance;
        worst.time = t;
        worst.detail = Format("the base passes via %zu", k) +
                       Format(" (%.3f, %.3f, %.3f)", point.x(), point.y(), point.z()) +
                       Format(" %.4f m from it at t = %.3f s", d, t) +
                       Format(" (tolerance %.4f m)", vias[k].tolerance) +
                       Format("; the worst of %zu vias", vias.size());
      }
      from = best;
    }
    worst.passed = passed;
    report->checks.push_back(worst);
  }

 private:
  const CheckInputs& in_;
  std::vector<std::pair<double, Vec3>> track_;  // (t, base position) per regular sample
};

}  // namespace

std::vector<std::unique_ptr<SampledCheck>> MakeSampledChecks(const CheckInputs& in) {
  const Limits& limits = in.task.limits;
  const double tolerance = in.options.limit_tolerance;
  std::vector<std::unique_ptr<SampledCheck>> checks;
  auto limit = [&](CheckKind kind, int joint, std::string name, std::function<double(const WholeBodySample&)> ratio) {
    checks.push_back(std::make_unique<LimitRatio>(kind, joint, std::move(name), tolerance, std::move(ratio)));
  };
  limit(CheckKind::kVelocity, -1, "velocity", [&limits](const WholeBodySample& s) { return s.velocity.norm() / limits.v_max; });
  limit(CheckKind::kAcceleration, -1, "acceleration",
        [&limits](const WholeBodySample& s) { return s.acceleration.norm() / limits.a_max; });
  limit(CheckKind::kYawRate, -1, "yaw_rate",
        [&limits](const WholeBodySample& s) { return std::abs(s.yaw_rate) / limits.yaw_rate_max; });
  limit(CheckKind::kBodyRateXY, -1, "body_rate_xy",
        [&limits](const WholeBodySample& s) { return s.body_rate.head<2>().norm() / limits.body_rate_xy_max; });
  const std::vector<std::string> joint_names = in.robot.ActuatedJointNames();
  for (int q = 0; q < in.robot.num_actuated(); ++q) {
    limit(CheckKind::kJointRate, q, joint_names[q] + "_rate",
          [&limits, q](const WholeBodySample& s) { return std::abs(s.joint_rates[q]) / limits.joint_rate_max[q]; });
  }
  checks.push_back(std::make_unique<JointLimits>(limits));
  checks.push_back(std::make_unique<StartAndEndStates>(in));
  if (in.insertion.enabled) checks.push_back(std::make_unique<InsertionLine>(in.insertion, in.options));
  if (!in.task.vias.empty()) checks.push_back(std::make_unique<ViaPassage>(in));
  return checks;
}

}  // namespace quadhand::planner

#include "quadhand/planner/time_scale.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "quadhand/core/text.h"

namespace quadhand::planner {
namespace {

bool AtRest(const Eigen::MatrixXd& boundary) {
  return boundary.rows() <= 1 || boundary.bottomRows(boundary.rows() - 1).cwiseAbs().maxCoeff() < 1e-9;
}

core::Result<traj::Minco> Scaled(const traj::Minco& m, double factor, bool keep_last_piece) {
  traj::Minco out;
  QUADHAND_RETURN_IF_ERROR(out.Reset(m.order(), m.dims(), m.num_pieces()));
  Eigen::MatrixXd head = m.head(), tail = m.tail();
  for (int k = 1; k < head.rows(); ++k) {
    head.row(k) /= std::pow(factor, k);
    tail.row(k) /= std::pow(factor, k);
  }
  Eigen::MatrixXd waypoints(m.dims(), m.num_pieces() - 1);
  for (int i = 0; i + 1 < m.num_pieces(); ++i) waypoints.col(i) = m.Evaluate(i, m.durations()[i], 0);
  QUADHAND_RETURN_IF_ERROR(out.SetBoundary(head, tail));
  Eigen::VectorXd durations = m.durations() * factor;
  if (keep_last_piece) durations[durations.size() - 1] = m.durations()[durations.size() - 1];
  QUADHAND_RETURN_IF_ERROR(out.Generate(waypoints, durations));
  return out;
}

}  // namespace

double PeakSpeed(const WholeBodyTrajectory& trajectory, double step) {
  double peak = 0.0;
  const double duration = trajectory.duration();
  const long count = static_cast<long>(std::ceil(duration / step));
  for (long k = 0; k <= count; ++k) {
    peak = std::max(peak, trajectory.Sample(std::min(duration, k * step)).velocity.norm());
  }
  return peak;
}

core::Result<PlanResult> SlowDown(const PlanResult& plan, double factor, const PlanningScene& scene,
                                  const Task& task, const PlannerOptions& options) {
  if (!plan.trajectory) return core::Status::InvalidArgument("SlowDown: the plan has no trajectory");
  if (!(std::isfinite(factor) && factor >= 1.0 && factor <= 1000.0)) {
    return core::Status::InvalidArgument(core::Format("SlowDown: factor %g is not in [1, 1000]", factor));
  }
  const WholeBodyTrajectory& original = *plan.trajectory;
  for (const traj::Minco* m : {&original.position(), &original.aux()}) {
    if (!AtRest(m->head()) || !AtRest(m->tail())) {
      return core::Status::InvalidArgument("SlowDown: the plan does not start and end at rest");
    }
  }
  const bool keep_last = plan.insertion.enabled && original.position().num_pieces() > 1;
  auto position = Scaled(original.position(), factor, keep_last);
  if (!position.ok()) return position.status();
  auto aux = Scaled(original.aux(), factor, keep_last);
  if (!aux.ok()) return aux.status();
  PlanResult slowed = plan;
  slowed.trajectory.emplace(std::move(*position), std::move(*aux), original.flatness());
  const auto begin = std::chrono::steady_clock::now();
  slowed.post_check = PostCheck(*slowed.trajectory, scene.robot, task, plan.terminal, plan.insertion, scene.collision,
                                scene.exact, scene.self_collision, options.post_check);
  slowed.post_check_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - begin).count();
  slowed.success = slowed.post_check.passed;
  slowed.status = slowed.success ? PlanStatus::kSuccess : PlanStatus::kPostCheckFailed;
  slowed.message = slowed.success ? core::Format("slowed down %.2fx", factor)
                                  : core::Format("slowed down %.2fx: ", factor) + slowed.post_check.FirstFailure();
  slowed.rejoined_at = -1.0;
  return slowed;
}

}  // namespace quadhand::planner

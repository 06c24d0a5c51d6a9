// The post-check's checks judged at its regular samples (post_check.h): the
// rate and joint limits, the start and end states and the insertion line,
// one class each, listed in one table (MakeSampledChecks). The clearance
// and self-clearance checks come from the certificate (post_check.cc),
// which measures between the samples too. A new check of the samples is a
// class here and a line in the table.
#pragma once

#include <memory>
#include <vector>

#include "quadhand/planner/post_check.h"

namespace quadhand::planner {

// What a check sees at one regular sample, in time order.
struct CheckedSample {
  double t = 0.0;
  const WholeBodySample* state = nullptr;
  Vec3 tool = Vec3::Zero();  // the insertion's tool link position (insertion enabled only)
};

// What the checks judge against; all outlive the checks.
struct CheckInputs {
  const WholeBodyTrajectory& trajectory;
  const robot::RobotModel& robot;
  const Task& task;
  const BoundaryState& terminal;
  const InsertionGoal& insertion;
  const PostCheckOptions& options;
};

class SampledCheck {
 public:
  virtual ~SampledCheck() = default;
  virtual void Observe(const CheckedSample& /*sample*/) {}
  // Appends its result (and any figures it reports) to *report.
  virtual void Finish(PostCheckReport* report) = 0;
};

// Every check of the samples, in the report's order.
std::vector<std::unique_ptr<SampledCheck>> MakeSampledChecks(const CheckInputs& inputs);

}  // namespace quadhand::planner

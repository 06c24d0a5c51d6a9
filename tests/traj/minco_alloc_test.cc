// The MINCO hot path (Generate, energy, sample gradients, propagation) does
// not allocate once the object and the output arrays have their sizes.
// support/allocation_counter.h replaces traj_test's operator new to count calls.
#include <gtest/gtest.h>

#include "quadhand/traj/minco.h"
#include "support/allocation_counter.h"

namespace quadhand::traj {
namespace {

using Eigen::MatrixXd;
using Eigen::VectorXd;

TEST(MincoAllocationTest, HotPathDoesNotAllocate) {
  for (int s = 1; s <= 4; ++s) {
    const int m = 3, n = 20;
    Minco minco;
    ASSERT_TRUE(minco.Reset(s, m, n).ok());
    ASSERT_TRUE(minco.SetBoundary(MatrixXd::Ones(s, m), MatrixXd::Zero(s, m)).ok());
    const MatrixXd q = MatrixXd::Random(m, n - 1);
    const VectorXd t = VectorXd::Constant(n, 0.7);
    MatrixXd gc = MatrixXd::Zero(2 * s * n, m), gq(m, n - 1), gh(s, m), gtl(s, m);
    VectorXd gt = VectorXd::Zero(n), total(n), sample = VectorXd::Ones(m), value(m);
    ASSERT_TRUE(minco.Generate(q, t).ok());  // warm-up

    const long before = quadhand::testing::AllocationCount();
    bool ok = minco.Generate(q, t).ok();
    double e = minco.Energy();
    minco.AddEnergyGradient(gc, gt);
    minco.Evaluate(3, 0.2, 1, value);
    minco.AddSampleGradient(3, 0.2, 1, sample, 0.3, gc, gt);
    ok = ok && minco.PropagateGradient(gc, gt, &gq, &total, &gh, &gtl).ok();
    ok = ok && minco.Reset(s, m, n).ok();  // same sizes: no-op
    const long after = quadhand::testing::AllocationCount();

    EXPECT_TRUE(ok);
    EXPECT_GT(e, 0.0);
    EXPECT_EQ(after - before, 0) << "s = " << s;
  }
}

}  // namespace
}  // namespace quadhand::traj

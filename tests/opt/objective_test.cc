#include "quadhand/opt/objective.h"

#include <gtest/gtest.h>

namespace quadhand::opt {
namespace {

FunctionObjective SumOfSquares(int n) {
  return FunctionObjective(n, [](const VecX& x, double* cost, VecX* grad) {
    *cost = x.squaredNorm();
    if (grad != nullptr) *grad = 2.0 * x;
    return true;
  });
}

TEST(ObjectiveTest, EvaluatesCostAndOptionalGradient) {
  const FunctionObjective f = SumOfSquares(3);
  EXPECT_EQ(f.num_variables(), 3);
  const VecX x = VecX::Constant(3, 2.0);
  double cost = 0.0;
  ASSERT_TRUE(f.Evaluate(x, &cost, nullptr));
  EXPECT_DOUBLE_EQ(cost, 12.0);
  VecX grad;  // empty: Evaluate sizes it
  ASSERT_TRUE(f.Evaluate(x, &cost, &grad));
  EXPECT_TRUE(grad.isApprox(VecX::Constant(3, 4.0)));
}

TEST(ObjectiveTest, RejectsWrongSizesAndNullCost) {
  const FunctionObjective f = SumOfSquares(3);
  double cost = 0.0;
  EXPECT_FALSE(f.Evaluate(VecX::Zero(2), &cost, nullptr));
  EXPECT_FALSE(f.Evaluate(VecX::Zero(3), nullptr, nullptr));
  const FunctionObjective shrinks(3, [](const VecX&, double* c, VecX* g) {
    *c = 0.0;
    if (g != nullptr) g->resize(1);
    return true;
  });
  VecX grad;
  EXPECT_FALSE(shrinks.Evaluate(VecX::Zero(3), &cost, &grad));
}

TEST(ObjectiveTest, PassesOnFailureAndToleratesAnEmptyFunction) {
  const FunctionObjective fails(1, [](const VecX&, double*, VecX*) { return false; });
  double cost = 0.0;
  EXPECT_FALSE(fails.Evaluate(VecX::Zero(1), &cost, nullptr));
  const FunctionObjective empty(1, nullptr);
  EXPECT_FALSE(empty.Evaluate(VecX::Zero(1), &cost, nullptr));
}

}  // namespace
}  // namespace quadhand::opt

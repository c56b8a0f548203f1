#include "core/robust_kernel.h"

#include <gtest/gtest.h>

namespace graphslam::core {
namespace {

TEST(RobustKernel, WeightIsTheDerivativeOfTheCost) {
  for (RobustKernel::Type type :
       {RobustKernel::Type::kNone, RobustKernel::Type::kHuber, RobustKernel::Type::kCauchy}) {
    for (double scale : {0.5, 1.0, 3.0}) {
      RobustKernel kernel{type, scale};
      for (double s : {1e-3, 0.1, 0.9, 2.0, 10.0, 1e4}) {
        if (type == RobustKernel::Type::kHuber && std::abs(s - scale * scale) < 1e-3) continue;
        const double h = 1e-6 * s;
        const double numeric = (kernel.Cost(s + h) - kernel.Cost(s - h)) / (2 * h);
        EXPECT_NEAR(kernel.Weight(s), numeric, 1e-6 * std::max(1.0, numeric))
            << RobustKernelName(kernel) << " s=" << s;
      }
      // Small errors are unaffected: rho(s) ~ s.
      EXPECT_NEAR(kernel.Cost(1e-8), 1e-8, 1e-14);
    }
  }
}

TEST(RobustKernel, OutliersAreBounded) {
  RobustKernel cauchy{RobustKernel::Type::kCauchy, 1.0};
  EXPECT_LT(cauchy.Cost(1e6), 20.0);
  EXPECT_LT(cauchy.Weight(1e6), 1e-5);
  RobustKernel huber{RobustKernel::Type::kHuber, 1.0};
  EXPECT_DOUBLE_EQ(huber.Cost(100.0), 2.0 * 10.0 - 1.0);
}

TEST(RobustKernel, ParsesNamesAndRejectsBadOnes) {
  StatusOr<RobustKernel> k = ParseRobustKernel("cauchy:2.5");
  ASSERT_TRUE(k.ok());
  EXPECT_EQ(k->type, RobustKernel::Type::kCauchy);
  EXPECT_DOUBLE_EQ(k->scale, 2.5);
  EXPECT_EQ(ParseRobustKernel("huber")->scale, 1.0);
  EXPECT_EQ(ParseRobustKernel("none")->type, RobustKernel::Type::kNone);
  EXPECT_EQ(ParseRobustKernel("tukey").status().message(),
            "unknown robust kernel 'tukey'; expected none, huber[:c] or cauchy[:c]");
  EXPECT_TRUE(ParseRobustKernel("cauchy:-1").status().IsInvalidArgument());
  EXPECT_TRUE(ParseRobustKernel("cauchy:x").status().IsInvalidArgument());
}

}  // namespace
}  // namespace graphslam::core

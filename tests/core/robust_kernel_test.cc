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

TEST(RobustKernel, PerConstraintTypeOptions) {
  RobustKernel observation;
  PoseFactorKernels pose;
  // The old single form keeps meaning observations.
  ASSERT_TRUE(ApplyRobustKernelOption("huber:2", &observation, &pose).ok());
  EXPECT_EQ(observation.type, RobustKernel::Type::kHuber);
  EXPECT_DOUBLE_EQ(observation.scale, 2.0);
  EXPECT_TRUE(pose.AllNone());
  ASSERT_TRUE(ApplyRobustKernelOption("observation=cauchy:1 odometry=huber:1.5,gps=huber:2",
                                      &observation, &pose)
                  .ok());
  EXPECT_EQ(observation.type, RobustKernel::Type::kCauchy);
  EXPECT_EQ(pose.relative_pose.type, RobustKernel::Type::kHuber);
  EXPECT_DOUBLE_EQ(pose.relative_pose.scale, 1.5);
  EXPECT_EQ(pose.motion.type, RobustKernel::Type::kHuber);  // odometry= covers motion
  EXPECT_DOUBLE_EQ(pose.gps.scale, 2.0);
  EXPECT_EQ(RobustKernelsName(observation, pose),
            "observation=cauchy:1 odometry=huber:1.5 gps=huber:2");
  ASSERT_TRUE(ApplyRobustKernelOption("motion=none", &observation, &pose).ok());
  EXPECT_EQ(pose.motion.type, RobustKernel::Type::kNone);
  EXPECT_EQ(pose.relative_pose.type, RobustKernel::Type::kHuber);
  // The name round-trips.
  RobustKernel observation2;
  PoseFactorKernels pose2;
  ASSERT_TRUE(
      ApplyRobustKernelOption(RobustKernelsName(observation, pose), &observation2, &pose2).ok());
  EXPECT_EQ(RobustKernelsName(observation2, pose2), RobustKernelsName(observation, pose));
  EXPECT_EQ(pose2.motion.type, RobustKernel::Type::kNone);
  EXPECT_EQ(RobustKernelsName(RobustKernel(), PoseFactorKernels()), "none");

  // Errors name the value and change nothing.
  const RobustKernel before = observation;
  Status bad = ApplyRobustKernelOption("observation=huber wheel=cauchy", &observation, &pose);
  EXPECT_TRUE(bad.IsInvalidArgument());
  EXPECT_EQ(bad.message(),
            "robust kernel 'wheel=cauchy': unknown constraint type 'wheel'; expected "
            "observation, odometry, motion, gps or robot");
  EXPECT_EQ(observation.type, before.type);
  EXPECT_TRUE(ApplyRobustKernelOption("gps=cauchy:0", &observation, &pose).IsInvalidArgument());
  EXPECT_TRUE(ApplyRobustKernelOption("gps=", &observation, &pose).IsInvalidArgument());
}

}  // namespace
}  // namespace graphslam::core

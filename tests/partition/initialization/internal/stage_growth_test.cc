// The stage schedule's settled test and the growth of the new poses it
// steers, on solver summaries whose chi2 sequences are chosen around the 1 %
// threshold of the last iteration's decrease.
#include "partition/initialization/internal/stage_growth.h"

#include <gtest/gtest.h>

#include <initializer_list>

namespace graphslam::partition::internal {
namespace {

// A solve from `initial` through the accepted chi2 values `after` (one per
// iteration), converged or stopped by its cap.
core::SolverSummary Solve(double initial, std::initializer_list<double> after, bool converged) {
  core::SolverSummary summary;
  summary.initial_chi2 = initial;
  summary.final_chi2 = initial;
  int k = 0;
  for (double chi2 : after) {
    core::IterationSummary it;
    it.iteration = ++k;
    it.chi2 = chi2;
    summary.per_iteration.push_back(it);
    summary.final_chi2 = chi2;
  }
  summary.converged = converged;
  return summary;
}

TEST(StageGrowth, UnsettledOnlyWhileTheLastIterationStillDescends) {
  // Capped while the last step lowered chi2 by 10 %: unsettled.
  EXPECT_TRUE(IsUnsettled(Solve(1e6, {1e4, 1100.0, 1000.0}, false)));
  // Capped after falling 100-fold, the last step lowering it by 0.5 %: settled.
  EXPECT_FALSE(IsUnsettled(Solve(1e6, {1e4, 1005.0, 1000.0}, false)));
  // A last step rejected (chi2 unchanged) after a steep descent: settled.
  EXPECT_FALSE(IsUnsettled(Solve(1e6, {1e4, 1000.0, 1000.0}, false)));
  // One iteration measured against the start.
  EXPECT_TRUE(IsUnsettled(Solve(1e6, {1e4}, false)));
  EXPECT_FALSE(IsUnsettled(Solve(1e4 * 1.005, {1e4}, false)));
  // Converged, or no iteration at all: never unsettled.
  EXPECT_FALSE(IsUnsettled(Solve(1e6, {1e4, 1100.0, 1000.0}, true)));
  EXPECT_FALSE(IsUnsettled(Solve(1e6, {}, false)));
}

TEST(StageGrowth, NewPosesHalveAfterAnUnsettledStageAndDoubleAfterASettledOne) {
  const core::SolverSummary unsettled = Solve(1e6, {1e4, 1100.0, 1000.0}, false);
  const core::SolverSummary settled = Solve(1e6, {1e4, 1005.0, 1000.0}, false);
  EXPECT_EQ(NextAllowedNewPoses(unsettled, 400, 25, 500), 200);
  EXPECT_EQ(NextAllowedNewPoses(unsettled, 40, 25, 500), 25);  // the floor
  EXPECT_EQ(NextAllowedNewPoses(settled, 200, 25, 500), 400);
  EXPECT_EQ(NextAllowedNewPoses(settled, 400, 25, 500), 500);  // the cap
}

TEST(StageGrowth, NextStageSizeGrowsGeometricallyWithinItsCap) {
  EXPECT_EQ(NextStageSize(2.0, 500, 100, 100000), 200);
  EXPECT_EQ(NextStageSize(2.0, 500, 1000, 100000), 1500);
  EXPECT_EQ(NextStageSize(2.0, 500, 99900, 100000), 100000);
  EXPECT_EQ(NextStageSize(1.0001, 500, 10, 100000), 11);  // at least one more
}

}  // namespace
}  // namespace graphslam::partition::internal

// Tests for core/unknown_layout.h: the anchored poses and the kept features'
// blocks, and no per-feature array when no feature is kept.
#include "core/unknown_layout.h"

#include <gtest/gtest.h>

#include <vector>

namespace graphslam::core {
namespace {

Problem2d ThreePoses() {
  Problem2d problem;
  for (int p = 0; p < 3; ++p) problem.AddPose(p, Pose2(p, 0, 0), true, 0);
  for (int f = 0; f < 4; ++f) problem.AddFeature(10 + f, Point2(f, 1), true);
  return problem;
}

TEST(UnknownLayout, KeptFeaturesFollowThePoses) {
  UnknownLayout layout = UnknownLayout::FromProblem(ThreePoses());
  // No GPS and no fixed pose: pose 0 is the anchor.
  EXPECT_EQ(layout.unknown_index, (std::vector<int32_t>{-1, 0, 1}));
  layout.KeepFeatures({0, 1, 0, 1});
  EXPECT_EQ(layout.num_kept_features, 2);
  EXPECT_EQ(layout.num_blocks(), 4);
  EXPECT_EQ(layout.feature_unknown_index, (std::vector<int32_t>{-1, 2, -1, 3}));
  EXPECT_FALSE(layout.IsKept(0));
  EXPECT_TRUE(layout.IsKept(1));
  EXPECT_TRUE(layout.IsKept(3));
}

// None kept (the usual case): no 4-byte index per feature is held, and a
// layout that kept some before keeps none after.
TEST(UnknownLayout, NoKeptFeatureHoldsNoPerFeatureArray) {
  UnknownLayout layout = UnknownLayout::FromProblem(ThreePoses());
  layout.KeepFeatures({1, 0, 0, 0});
  ASSERT_TRUE(layout.IsKept(0));
  layout.KeepFeatures({0, 0, 0, 0});
  EXPECT_EQ(layout.num_kept_features, 0);
  EXPECT_EQ(layout.num_blocks(), 2);
  EXPECT_TRUE(layout.feature_unknown_index.empty());
  EXPECT_EQ(layout.feature_unknown_index.capacity(), 0u);
  for (int32_t f = 0; f < 4; ++f) EXPECT_FALSE(layout.IsKept(f));
}

}  // namespace
}  // namespace graphslam::core

// The windows of the incremental association pass's stages
// (partition/association/windowed_stage.h): which poses a stage re-solves
// (the whole prefix until the window leaves pose 0 and at every full stage,
// never cutting into the new poses), and the window sub-problem at its
// boundary: the features seen from the window with their earlier sightings
// from fixed poses, extra features by their sightings alone, nothing from a
// pose at or after the stage's end and nothing left out by its label.
#include "partition/association/windowed_stage.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <numeric>
#include <set>
#include <utility>
#include <vector>

#include "core/se2.h"

namespace graphslam::partition {
namespace {

// observations_before of `poses` poses with one observation each.
std::vector<int64_t> OnePerPose(int64_t poses) {
  std::vector<int64_t> before(poses + 1);
  std::iota(before.begin(), before.end(), 0);
  return before;
}

TEST(StageWindows, WholePrefixUntilTheWindowLeavesPoseZeroThenAtEachDoubling) {
  StageWindowOptions options;
  options.window_poses = 100;
  options.window_observations = 50;  // reaches less far back than 100 poses
  const std::vector<int64_t> before = OnePerPose(1000);
  StageWindows windows(options, before);
  std::vector<int32_t> got;
  for (int32_t begin = 0; begin < 500; begin += 50) got.push_back(windows.Begin(begin, begin + 50));
  // Stages end at 50, 100, ...: the window of 100 poses reaches pose 0 up to
  // end 100; then [end - 100, end), except at ends 200 and 400 (twice the
  // last whole prefix, 100 and 200).
  const std::vector<int32_t> expected = {0, 0, 50, 0, 150, 200, 250, 0, 350, 400};
  EXPECT_EQ(got, expected);
}

TEST(StageWindows, ObservationsReachFurtherOnASparseLog) {
  StageWindowOptions options;
  options.window_poses = 10;
  options.window_observations = 30;
  options.full_stage_growth = 0.0;
  // One observation every fifth pose: 30 observations span 150 poses.
  std::vector<int64_t> before(1001, 0);
  for (int p = 0; p < 1000; ++p) before[p + 1] = before[p] + (p % 5 == 0 ? 1 : 0);
  StageWindows windows(options, before);
  const int32_t begin = windows.Begin(900, 950);
  EXPECT_GE(before[950] - before[begin], 30);
  EXPECT_LT(before[950] - before[begin + 1], 30);
  EXPECT_LT(begin, 950 - 10);
}

TEST(StageWindows, NeverCutsIntoTheNewPosesAndOffIsTheWholePrefix) {
  StageWindowOptions options;
  options.window_poses = 0;
  options.window_observations = 0;
  options.full_stage_growth = 0.0;
  const std::vector<int64_t> before = OnePerPose(100);
  {
    StageWindows windows(options, before);
    EXPECT_EQ(windows.Begin(0, 10), 0);
    EXPECT_EQ(windows.Begin(10, 30), 10);
    EXPECT_EQ(windows.Begin(30, 100), 30);
  }
  options.enabled = false;
  StageWindows off(options, before);
  EXPECT_EQ(off.Begin(0, 10), 0);
  EXPECT_EQ(off.Begin(10, 30), 0);
}

TEST(StageWindows, OptionsAreValidated) {
  StageWindowOptions options;
  EXPECT_TRUE(options.Validate().ok());
  options.window_observations = -1;
  EXPECT_FALSE(options.Validate().ok());
  options = StageWindowOptions();
  options.full_stage_growth = 0.5;
  EXPECT_FALSE(options.Validate().ok());
  options.full_stage_growth = 0.0;
  EXPECT_TRUE(options.Validate().ok());
}

// Ten poses on a line joined by odometry, pose 0 fixed. Label 0 is seen from
// every pose, label 1 from poses 0 and 1, label 2 from pose 2; one more
// observation of pose 8 is labelled -1.
struct Line {
  core::Problem2d problem;
  std::vector<int32_t> label;
  std::vector<core::Point2> positions = {core::Point2(5, 3), core::Point2(1, 3),
                                         core::Point2(2, -3)};
};

Line MakeLine() {
  Line line;
  core::Problem2d& problem = line.problem;
  for (int p = 0; p < 10; ++p) problem.AddPose(p, core::Pose2(p, 0, 0), true, 0, p);
  problem.pose_fixed[0] = 1;
  for (int p = 0; p + 1 < 10; ++p) {
    core::RelativePoseConstraint c;
    c.from = p;
    c.to = p + 1;
    c.z = core::Pose2(1, 0, 0);
    c.information = Eigen::Matrix3d::Identity();
    problem.relative_poses.push_back(c);
  }
  auto observe = [&](int p, int32_t label) {
    core::Observation o;
    o.pose = p;
    o.kind = core::ObservationKind::kPointXY;
    const core::Point2 at = label >= 0 ? line.positions[label] : core::Point2(8, 1);
    o.z = at - core::Point2(p, 0);
    o.information = Eigen::Matrix2d::Identity();
    o.feature = problem.AddFeature(core::kNoFeatureId, core::Point2::Zero(), false);
    problem.observations.push_back(o);
    line.label.push_back(label);
  };
  for (int p = 0; p < 10; ++p) observe(p, 0);
  observe(0, 1);
  observe(1, 1);
  observe(2, 2);
  observe(8, -1);
  return line;
}

TEST(WindowedStageBuilder, WindowBoundary) {
  const Line line = MakeLine();
  StageWindowOptions options;
  options.max_prior_observations_per_feature = 2;
  options.loop_closure_poses = 0;
  WindowedStageBuilder builder(options, line.problem);
  WindowedSubProblem out;
  // The window [5, 9) of the stage of new poses [7, 9); label 1 is extra.
  builder.Build(5, 7, 9, line.problem.poses, line.label, line.positions, {1}, &out);
  const core::Problem2d& sub = out.sub;

  EXPECT_EQ(out.unknown_poses, (std::vector<int32_t>{5, 6, 7, 8}));
  ASSERT_EQ(out.local_poses.size(), 4u);
  std::set<int32_t> global_of_fixed;
  for (int32_t local = 0; local < sub.num_poses(); ++local) {
    const auto it = std::find(out.local_poses.begin(), out.local_poses.end(), local);
    const int32_t global = static_cast<int32_t>(sub.pose_ids[local]);
    if (it == out.local_poses.end()) {
      EXPECT_TRUE(sub.pose_fixed[local]) << "pose " << global;
      global_of_fixed.insert(global);
    } else {
      EXPECT_FALSE(sub.pose_fixed[local]) << "pose " << global;
      EXPECT_EQ(global, out.unknown_poses[it - out.local_poses.begin()]);
    }
    EXPECT_EQ(sub.poses[local], line.problem.poses[global]);
  }
  // Pose 4 (odometry into the window) and the poses of the earlier
  // sightings: label 0's two of poses 0..4, evenly spaced (1 and 4), and
  // label 1's (0 and 1). Pose 9 is not placed yet.
  EXPECT_EQ(global_of_fixed, (std::set<int32_t>{0, 1, 4}));
  EXPECT_EQ(sub.relative_poses.size(), 4u);  // 4-5 .. 7-8

  ASSERT_EQ(out.local_of_label.size(), 3u);
  ASSERT_GE(out.local_of_label[0], 0);
  ASSERT_GE(out.local_of_label[1], 0);
  EXPECT_EQ(out.local_of_label[2], -1);  // seen below the window only, not extra
  EXPECT_EQ(sub.features[out.local_of_label[0]], line.positions[0]);
  EXPECT_EQ(sub.features[out.local_of_label[1]], line.positions[1]);
  std::multiset<std::pair<int64_t, int32_t>> seen;  // (global pose, label)
  for (const core::Observation& o : sub.observations) {
    const int32_t label = o.feature == out.local_of_label[0] ? 0 : 1;
    seen.emplace(sub.pose_ids[o.pose], label);
  }
  const std::multiset<std::pair<int64_t, int32_t>> expected = {
      {5, 0}, {6, 0}, {7, 0}, {8, 0}, {1, 0}, {4, 0}, {0, 1}, {1, 1}};
  EXPECT_EQ(seen, expected);
}

}  // namespace
}  // namespace graphslam::partition

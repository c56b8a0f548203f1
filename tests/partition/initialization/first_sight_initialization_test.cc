// FirstSightInitialization (partition/initialization/first_sight_initialization.h): Table 1
// from first sights on disk plus the joining observations gives, bit for bit,
// core::InitializeProblem's guesses and connectivity verdict on every
// observation; nothing per feature stays in memory and the scratch file goes.
#include "partition/initialization/first_sight_initialization.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include "core/initialization.h"
#include "tests/testing/random_problem.h"

namespace graphslam::partition {
namespace {

class FirstSightInitializationTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const ::testing::TestInfo* info = ::testing::UnitTest::GetInstance()->current_test_info();
    root_ = std::filesystem::temp_directory_path() /
            ("graphslam_first_sight_" + std::string(info->name()) + "_" +
             std::to_string(::getpid()));
    std::filesystem::remove_all(root_);
    std::filesystem::create_directories(root_);
  }
  void TearDown() override { std::filesystem::remove_all(root_); }
  std::string Scratch() const { return (root_ / kFirstSightScratchName).string(); }

  // A random problem whose features have no guess and whose observations come
  // in a shuffled order, so a feature's first sight is neither its lowest pose
  // nor its first observation in pose order.
  static core::Problem2d ShuffledProblem(uint32_t seed) {
    testing::RandomProblemOptions options;
    options.num_poses = 120;
    options.num_features = 60;
    options.seed = seed;
    core::Problem2d problem = testing::MakeRandomProblem(options).problem;
    std::fill(problem.feature_initialized.begin(), problem.feature_initialized.end(), 0);
    std::mt19937 rng(seed);
    std::shuffle(problem.observations.begin(), problem.observations.end(), rng);
    return problem;
  }

  // Pass 1 as the ingest runs it, then Initialize on the pose-only copy.
  Status InitializeStreamed(const core::Problem2d& problem, core::Problem2d* pose_only,
                            int64_t* joining = nullptr) {
    *pose_only = problem;
    pose_only->observations.clear();
    FirstSightInitialization init(Scratch());
    FeatureIndex index;
    for (const core::Observation& o : problem.observations) {
      GS_RETURN_IF_ERROR(init.Add(o, index));
      index.Add(o);
    }
    if (joining != nullptr) *joining = static_cast<int64_t>(init.joining().size());
    EXPECT_EQ(init.first_sights(), static_cast<int64_t>(problem.num_features()));
    return init.Initialize(pose_only);
  }

  std::filesystem::path root_;
};

TEST_F(FirstSightInitializationTest, GuessesEqualInitializeProblemOnEveryObservation) {
  for (uint32_t seed : {1u, 2u, 3u}) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    core::Problem2d all = ShuffledProblem(seed);
    core::Problem2d streamed;
    int64_t joining = 0;
    ASSERT_TRUE(InitializeStreamed(all, &streamed, &joining).ok());
    EXPECT_LT(joining, all.num_poses());  // at most poses - 1 kept in memory
    EXPECT_FALSE(std::filesystem::exists(Scratch())) << "scratch left behind";
    EXPECT_TRUE(streamed.observations.empty());

    // Placing by a wrong observation (e.g. the last one of each feature, or
    // the one from its lowest pose) gives other guesses: the test can fail.
    core::Problem2d last_sight = all;
    std::reverse(last_sight.observations.begin(), last_sight.observations.end());
    ASSERT_TRUE(core::InitializeProblem(&last_sight).ok());
    ASSERT_TRUE(core::InitializeProblem(&all).ok());
    int differ = 0;
    for (int32_t f = 0; f < all.num_features(); ++f) {
      ASSERT_EQ(streamed.feature_initialized[f], 1) << "feature " << f;
      EXPECT_EQ(all.features[f], streamed.features[f]) << "feature " << f;
      differ += last_sight.features[f] != all.features[f];
    }
    EXPECT_GT(differ, all.num_features() / 2);
    for (int32_t p = 0; p < all.num_poses(); ++p) EXPECT_EQ(all.poses[p], streamed.poses[p]);
  }
}

TEST_F(FirstSightInitializationTest, InputGuessesAreKept) {
  core::Problem2d all = ShuffledProblem(4);
  for (int32_t f = 0; f < all.num_features(); f += 3) {
    all.feature_initialized[f] = 1;
    all.features[f] = core::Point2(100.0 + f, -7.0);
  }
  core::Problem2d streamed;
  ASSERT_TRUE(InitializeStreamed(all, &streamed).ok());
  ASSERT_TRUE(core::InitializeProblem(&all).ok());
  for (int32_t f = 0; f < all.num_features(); ++f)
    EXPECT_EQ(all.features[f], streamed.features[f]) << "feature " << f;
  EXPECT_EQ(streamed.features[3], core::Point2(103.0, -7.0));
}

// Without odometry the poses are tied only through shared features: the
// verdict (and its message) is the one of all observations, connected or not.
TEST_F(FirstSightInitializationTest, ConnectivityThroughFeaturesHasTheSameVerdict) {
  core::Problem2d linked = ShuffledProblem(5);
  linked.relative_poses.clear();
  core::Problem2d streamed;
  const Status all_status = core::ValidateProblem(linked);
  EXPECT_EQ(InitializeStreamed(linked, &streamed).ToString(), all_status.ToString());

  // Pose 60 loses every observation but one of a feature nobody else sees:
  // it is cut off, and both say so with the same message.
  core::Problem2d cut = linked;
  std::vector<core::Observation> kept;
  for (const core::Observation& o : cut.observations)
    if (o.pose != 60) kept.push_back(o);
  core::Observation lonely;
  lonely.pose = 60;
  lonely.feature = cut.AddFeature(999999, core::Point2(0, 0), false);
  lonely.z = Eigen::Vector2d(1.0, 0.1);
  lonely.information = Eigen::Matrix2d::Identity();
  kept.push_back(lonely);
  cut.observations = kept;
  const Status cut_status = core::ValidateProblem(cut);
  ASSERT_FALSE(cut_status.ok());
  EXPECT_EQ(InitializeStreamed(cut, &streamed).ToString(), cut_status.ToString());
}

// A first sight with a bad information matrix is checked although it is not
// in memory when InitializeProblem runs.
TEST_F(FirstSightInitializationTest, FirstSightsAreChecked) {
  core::Problem2d all = ShuffledProblem(6);
  all.observations[0].information(1, 1) = -1.0;  // the first sight of its feature
  core::Problem2d streamed;
  const Status status = InitializeStreamed(all, &streamed);
  EXPECT_EQ(status.ToString(), core::ValidateProblem(all).ToString());
  EXPECT_NE(status.ToString().find("observation of feature"), std::string::npos)
      << status.ToString();
}

}  // namespace
}  // namespace graphslam::partition

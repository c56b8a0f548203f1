// LocalizeFromFeatures (partition/initialization/feature_localization.h)
// against ground truth: the closed-form alignment recovers a known rigid
// motion exactly (headings across +-pi too); a pose whose guess is metres
// and radians off is put within the measurement noise of the truth by its
// noisy range-bearing observations of placed features; and the guess is kept
// when the pose sees too few placed features, when the placed features
// disagree among themselves, when they are bunched in one spot (they leave
// the pose free to swing about it), and for bearing-only observations.
#include "partition/initialization/feature_localization.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include "core/angle.h"
#include "core/observation_models.h"
#include "core/se2.h"

namespace graphslam::partition {
namespace {

using core::Point2;
using core::Pose2;

TEST(AlignPoints2d, RecoversARigidMotionExactly) {
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> uniform(-8.0, 8.0);
  std::vector<Point2> local;
  for (int i = 0; i < 12; ++i) local.emplace_back(uniform(rng), uniform(rng));
  for (const Pose2& truth : {Pose2(3.0, -2.0, 0.4), Pose2(-150.0, 40.0, 3.1),
                             Pose2(7.0, 7.0, -3.1), Pose2(0.0, 0.0, 0.0)}) {
    std::vector<Point2> global;
    for (const Point2& l : local) global.push_back(core::TransformPoint(truth, l));
    const Pose2 aligned = AlignPoints2d(local, global);
    EXPECT_NEAR(aligned.x(), truth.x(), 1e-9);
    EXPECT_NEAR(aligned.y(), truth.y(), 1e-9);
    EXPECT_NEAR(core::WrapAngle(aligned.z() - truth.z()), 0.0, 1e-12) << truth.z();
  }
}

// A pose at `truth` seeing `n` features within 8 m, placed at their true
// positions, by range-bearing observations with the given noise.
struct Scene {
  core::Problem2d problem;
  std::vector<uint8_t> placed;
};

Scene MakeScene(const Pose2& truth, int n, uint32_t seed,
                core::ObservationKind kind = core::ObservationKind::kRangeBearing) {
  Scene s;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> range(1.0, 8.0);
  std::uniform_real_distribution<double> bearing(-std::numbers::pi, std::numbers::pi);
  std::normal_distribution<double> normal(0.0, 1.0);
  const double sigma_range = 0.1, sigma_bearing = 0.02;
  s.problem.AddPose(0, truth, true, 0);
  for (int i = 0; i < n; ++i) {
    const double r = range(rng), b = bearing(rng);
    const Point2 feature = core::TransformPoint(truth, Point2(r * std::cos(b), r * std::sin(b)));
    const int32_t f = s.problem.AddFeature(i, feature, true);
    core::Observation o;
    o.pose = 0;
    o.feature = f;
    o.kind = kind;
    o.z = kind == core::ObservationKind::kBearing
              ? Eigen::Vector2d(b + sigma_bearing * normal(rng), 0.0)
              : Eigen::Vector2d(r + sigma_range * normal(rng), b + sigma_bearing * normal(rng));
    o.information = Eigen::Vector2d(1.0 / (sigma_range * sigma_range),
                                    1.0 / (sigma_bearing * sigma_bearing))
                        .asDiagonal();
    if (kind == core::ObservationKind::kBearing)
      o.information = Eigen::Vector2d(1.0 / (sigma_bearing * sigma_bearing), 1.0).asDiagonal();
    s.problem.observations.push_back(o);
    s.placed.push_back(1);
  }
  return s;
}

TEST(LocalizeFromFeatures, PutsAFarGuessOntoTheTruth) {
  const Pose2 truth(120.0, -35.0, 2.9);
  for (uint32_t seed = 1; seed <= 5; ++seed) {
    const Scene s = MakeScene(truth, 60, seed);
    // 6 m and 2.6 rad off: the guess fits none of the features.
    const Pose2 guess(125.0, -32.0, -0.5);
    Pose2 pose;
    const FeatureLocalization result =
        LocalizeFromFeatures(FeatureLocalizationOptions(), s.problem.observations,
                             s.problem.features, s.placed, guess, &pose);
    EXPECT_TRUE(result.localized);
    EXPECT_TRUE(result.closed_form_chosen);
    EXPECT_EQ(result.features, 60);
    EXPECT_LT(result.chi2, result.guess_chi2);
    // Within the noise: ~0.1 m range, 0.02 rad bearing over 60 features.
    EXPECT_LT((pose.head<2>() - truth.head<2>()).norm(), 0.1) << "seed " << seed;
    EXPECT_LT(std::abs(core::WrapAngle(pose.z() - truth.z())), 0.02) << "seed " << seed;
    // Gauss-Newton from the closed form: chi2 about the residual dimension.
    EXPECT_LT(result.chi2, 2.0 * 2 * 60) << "seed " << seed;
  }
}

TEST(LocalizeFromFeatures, KeepsTheGuessWithTooFewPlacedFeatures) {
  const Pose2 truth(0.0, 0.0, 0.3), guess(2.0, 1.0, 0.0);
  Scene s = MakeScene(truth, 20, 7);
  // 13 of the 20 unplaced: 7 placed, one short of the default 8.
  for (int i = 0; i < 13; ++i) s.placed[i] = 0;
  Pose2 pose;
  FeatureLocalization result = LocalizeFromFeatures(
      FeatureLocalizationOptions(), s.problem.observations, s.problem.features, s.placed,
      guess, &pose);
  EXPECT_FALSE(result.localized);
  EXPECT_EQ(result.features, 7);
  EXPECT_EQ(pose, guess);
  s.placed[0] = 1;  // 8: localized
  result = LocalizeFromFeatures(FeatureLocalizationOptions(), s.problem.observations,
                                s.problem.features, s.placed, guess, &pose);
  EXPECT_TRUE(result.localized);
  EXPECT_LT((pose.head<2>() - truth.head<2>()).norm(), 0.2);
}

TEST(LocalizeFromFeatures, KeepsTheGuessWhenPlacedFeaturesDisagree) {
  // Half the features placed 6 m away from where the pose sees them (a place
  // revisited after drift): no rigid motion fits both halves.
  const Pose2 truth(10.0, 5.0, -1.0), guess(11.0, 5.5, -0.8);
  Scene s = MakeScene(truth, 40, 9);
  for (int j = 0; j < 20; ++j) s.problem.features[j] += Point2(6.0, 0.0);
  Pose2 pose;
  const FeatureLocalization result = LocalizeFromFeatures(
      FeatureLocalizationOptions(), s.problem.observations, s.problem.features, s.placed,
      guess, &pose);
  EXPECT_FALSE(result.localized);
  EXPECT_EQ(pose, guess);
  EXPECT_GT(result.chi2, FeatureLocalizationOptions().max_chi2_per_observation * 40);
}

TEST(LocalizeFromFeatures, KeepsTheGuessWhenBunchedFeaturesLeaveItFree) {
  // 15 features within 0.1 m of one spot 8 m ahead (the few a pose after a
  // feature-free stretch shares with its predecessor in a dense campus):
  // swinging the pose about the spot keeps every range and bearing, so they
  // pin neither its heading nor its position, and the guess 0.1 rad off
  // stays.
  const Pose2 truth(40.0, 20.0, 1.2), guess(40.3, 19.8, 1.3);
  for (uint32_t seed = 1; seed <= 5; ++seed) {
    Scene s = MakeScene(truth, 15, seed);
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> offset(-0.1, 0.1);
    std::normal_distribution<double> normal(0.0, 1.0);
    for (core::Observation& o : s.problem.observations) {
      const Point2 local(8.0 + offset(rng), offset(rng));
      s.problem.features[o.feature] = core::TransformPoint(truth, local);
      o.z = Eigen::Vector2d(local.norm() + 0.1 * normal(rng),
                            std::atan2(local.y(), local.x()) + 0.02 * normal(rng));
    }
    Pose2 pose;
    const FeatureLocalization result = LocalizeFromFeatures(
        FeatureLocalizationOptions(), s.problem.observations, s.problem.features, s.placed,
        guess, &pose);
    EXPECT_FALSE(result.localized) << "seed " << seed;
    EXPECT_EQ(pose, guess) << "seed " << seed;
    EXPECT_GT(result.heading_sigma, FeatureLocalizationOptions().max_heading_sigma)
        << "seed " << seed;
  }
  // The same number of features spread over the field pin it to 0.01 rad.
  const Scene s = MakeScene(truth, 15, 3);
  Pose2 pose;
  const FeatureLocalization result = LocalizeFromFeatures(
      FeatureLocalizationOptions(), s.problem.observations, s.problem.features, s.placed,
      guess, &pose);
  EXPECT_TRUE(result.localized);
  EXPECT_LT(result.heading_sigma, 0.01);
  EXPECT_LT(std::abs(core::WrapAngle(pose.z() - truth.z())), 0.03);
}

TEST(LocalizeFromFeatures, IgnoresBearingOnlyObservations) {
  const Pose2 truth(0.0, 0.0, 0.0), guess(1.0, 1.0, 0.5);
  const Scene s = MakeScene(truth, 30, 3, core::ObservationKind::kBearing);
  Pose2 pose;
  const FeatureLocalization result = LocalizeFromFeatures(
      FeatureLocalizationOptions(), s.problem.observations, s.problem.features, s.placed,
      guess, &pose);
  EXPECT_FALSE(result.localized);
  EXPECT_EQ(result.features, 0);
  EXPECT_EQ(pose, guess);
}

}  // namespace
}  // namespace graphslam::partition

// Tests of UniqueCompatibleFeature (partition/association/provisional_rescue.h):
// the chi2 it gates is the sum of the sightings' chi2 at the given poses, and
// only a unique compatible feature is returned.
#include "partition/association/provisional_rescue.h"

#include <gtest/gtest.h>

#include <random>

#include "core/observation_models.h"

namespace graphslam::partition {
namespace {

core::Observation Sighting(int32_t pose, const core::Pose2& at, const core::Point2& landmark,
                           core::ObservationKind kind, const Eigen::Matrix2d& information) {
  core::Observation o;
  o.pose = pose;
  o.kind = kind;
  o.information = information;
  Eigen::Vector2d e;
  o.z = Eigen::Vector2d::Zero();
  // The exact measurement: h(x, m) is the residual at z = 0 (bearing wrapped).
  EXPECT_TRUE(core::EvaluateObservation(kind, at, landmark, o.z, &e, nullptr, nullptr));
  o.z = e;
  return o;
}

double Chi2(const core::Observation& o, const core::Pose2& pose, const core::Point2& m) {
  Eigen::Vector2d e;
  EXPECT_TRUE(core::EvaluateObservation(o.kind, pose, m, o.z, &e, nullptr, nullptr));
  return e.dot(o.information * e);
}

TEST(ProvisionalRescue, GatesTheSumOfTheSightingsChi2) {
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0.0, 1.0);
  for (core::ObservationKind kind :
       {core::ObservationKind::kPointXY, core::ObservationKind::kRangeBearing}) {
    const std::vector<core::Pose2> poses = {core::Pose2(0.0, 0.0, 0.1),
                                            core::Pose2(2.0, -1.0, 0.7)};
    const core::Point2 tree(6.0, 3.0);
    const Eigen::Matrix2d information = Eigen::Vector2d(25.0, 400.0).asDiagonal();
    std::vector<core::Observation> seen = {Sighting(0, poses[0], tree, kind, information),
                                           Sighting(1, poses[1], tree, kind, information)};
    for (core::Observation& o : seen) o.z += 0.05 * Eigen::Vector2d(noise(rng), noise(rng));
    const std::vector<const core::Observation*> sightings = {&seen[0], &seen[1]};
    // Candidates: the tree moved by growing offsets.
    std::vector<core::Point2> features;
    for (double d : {0.0, 0.1, 0.2, 0.4, 0.8}) features.push_back(tree + core::Point2(d, -d));
    auto both = [&](const core::Point2& m) {
      return Chi2(seen[0], poses[0], m) + Chi2(seen[1], poses[1], m);
    };
    for (size_t f = 0; f < features.size(); ++f) {
      const double chi2 = both(features[f]);
      // A gate just above this candidate's chi2 and below every other's
      // accepts it alone; just below, it is not accepted.
      bool alone = true;
      for (size_t g = 0; g < features.size(); ++g) {
        if (g != f && both(features[g]) <= chi2 * 1.001) alone = false;
      }
      const std::vector<core::Point2> one = {features[f]};
      EXPECT_EQ(UniqueCompatibleFeature(sightings, poses, one, chi2 * 1.001), 0);
      EXPECT_EQ(UniqueCompatibleFeature(sightings, poses, one, chi2 * 0.999), -1);
      if (alone) {
        EXPECT_EQ(UniqueCompatibleFeature(sightings, poses, features, chi2 * 1.001),
                  static_cast<int32_t>(f));
      }
    }
  }
}

TEST(ProvisionalRescue, TwoCompatibleFeaturesOrNoneGiveNone) {
  const std::vector<core::Pose2> poses = {core::Pose2(0.0, 0.0, 0.0)};
  const Eigen::Matrix2d information = 100.0 * Eigen::Matrix2d::Identity();
  const core::Observation seen =
      Sighting(0, poses[0], core::Point2(5.0, 0.0), core::ObservationKind::kPointXY, information);
  const std::vector<const core::Observation*> sightings = {&seen};
  // Two features 0.1 m on either side: chi2 1 each.
  const std::vector<core::Point2> both = {core::Point2(5.0, 0.1), core::Point2(5.0, -0.1)};
  EXPECT_EQ(UniqueCompatibleFeature(sightings, poses, both, 14.0), -1);
  EXPECT_EQ(UniqueCompatibleFeature(sightings, poses, both, 0.5), -1);
  const std::vector<core::Point2> apart = {core::Point2(5.0, 0.1), core::Point2(8.0, 0.0)};
  EXPECT_EQ(UniqueCompatibleFeature(sightings, poses, apart, 14.0), 0);
  EXPECT_EQ(UniqueCompatibleFeature(sightings, poses, {}, 14.0), -1);
}

}  // namespace
}  // namespace graphslam::partition

// LinearizeFeature's reduced modes and precomputed pose frames against its
// full mode: the quantities each mode promises are the full mode's, to the
// bit (the streaming passes rely on it: the screening's C, the recovery's C,
// g_m and H_pm, the pose frames' Jacobians). The full mode itself is checked
// against the dense Schur complement in chunk_passes_test.
#include "core/feature_linearizer.h"

#include <gtest/gtest.h>

#include "partition/ingest/in_memory_chunk_source.h"
#include "tests/testing/random_problem.h"

namespace graphslam::core {
namespace {

// Bit equality of two matrices (==, so that a NaN anywhere fails).
template <class A, class B>
bool SameBits(const A& a, const B& b) {
  return a.rows() == b.rows() && a.cols() == b.cols() && (a.array() == b.array()).all();
}

class FeatureLinearizerTest : public ::testing::TestWithParam<std::tuple<bool, bool>> {};

TEST_P(FeatureLinearizerTest, ReducedModesAndPoseFramesGiveTheFullModesNumbers) {
  const auto [range_bearing, robust] = GetParam();
  RobustKernel kernel;
  if (robust) {
    kernel.type = RobustKernel::Type::kHuber;
    kernel.scale = 1.0;
  }
  int64_t features_checked = 0;
  int64_t weighted_observations = 0;  // observations the kernel down-weights
  for (uint32_t seed = 1; seed <= 4; ++seed) {
    // Without GPS, pose 0 is anchored.
    const Problem2d problem = testing::MakeRandomProblem({.num_poses = 20,
                                                          .num_features = 10,
                                                          .range_bearing = range_bearing,
                                                          .gps_every = seed % 2 == 0 ? 5 : 0,
                                                          .seed = seed})
                                  .problem;
    partition::ChunkingOptions chunking;
    chunking.max_observations_per_chunk = 9;
    const partition::InMemoryChunkSource chunks(problem, chunking);
    const UnknownLayout layout = UnknownLayout::FromProblem(problem);
    const std::vector<Space2d::PoseFrame> frames = PoseFrames<Space2d>(problem.poses);

    ObservationChunk chunk;
    LinearizedFeature full, framed, coupling, information;
    for (int64_t c = 0; c < chunks.NumChunks(); ++c) {
      ASSERT_TRUE(chunks.Load(c, &chunk).ok());
      for (int64_t k = 0; k < chunk.num_features(); ++k) {
        const Point2& feature = problem.features[chunk.features[k]];
        LinearizeFeature<Space2d>(chunk, k, problem.poses, feature, layout, kernel, &full);
        LinearizeFeature<Space2d>(chunk, k, problem.poses, feature, layout, kernel, &framed,
                                  LinearizeWhat::kAll, frames.data());
        LinearizeFeature<Space2d>(chunk, k, problem.poses, feature, layout, kernel, &coupling,
                                  LinearizeWhat::kFeatureAndCoupling, frames.data());
        LinearizeFeature<Space2d>(chunk, k, problem.poses, feature, layout, kernel, &information,
                                  LinearizeWhat::kInformation);
        ASSERT_FALSE(full.blocks.poses.empty());
        ASSERT_GT(full.chi2, 0.0);
        ++features_checked;

        // With frames: everything, to the bit.
        EXPECT_TRUE(SameBits(framed.blocks.feature_information, full.blocks.feature_information));
        EXPECT_TRUE(SameBits(framed.blocks.feature_gradient, full.blocks.feature_gradient));
        ASSERT_EQ(framed.blocks.poses, full.blocks.poses);
        for (size_t s = 0; s < full.blocks.poses.size(); ++s) {
          EXPECT_TRUE(SameBits(framed.blocks.pose_feature[s], full.blocks.pose_feature[s]));
          EXPECT_TRUE(SameBits(framed.pose_hessian[s], full.pose_hessian[s]));
          EXPECT_TRUE(SameBits(framed.pose_gradient[s], full.pose_gradient[s]));
        }
        EXPECT_EQ(framed.chi2, full.chi2);

        // The recovery's mode: C, g_m, the poses and H_pm.
        EXPECT_TRUE(
            SameBits(coupling.blocks.feature_information, full.blocks.feature_information));
        EXPECT_TRUE(SameBits(coupling.blocks.feature_gradient, full.blocks.feature_gradient));
        ASSERT_EQ(coupling.blocks.poses, full.blocks.poses);
        ASSERT_EQ(coupling.blocks.pose_feature.size(), full.blocks.poses.size());
        for (size_t s = 0; s < full.blocks.poses.size(); ++s)
          EXPECT_TRUE(SameBits(coupling.blocks.pose_feature[s], full.blocks.pose_feature[s]));
        EXPECT_EQ(coupling.degenerate_observations, full.degenerate_observations);

        // The screening's mode: C (weighted by the kernel, so the residual is
        // evaluated when there is one).
        EXPECT_TRUE(
            SameBits(information.blocks.feature_information, full.blocks.feature_information));
        EXPECT_EQ(information.degenerate_observations, full.degenerate_observations);

        if (robust) {
          for (int64_t o = chunk.feature_begin[k]; o < chunk.feature_begin[k + 1]; ++o) {
            Eigen::Vector2d residual;
            const Observation& observation = chunk.observations[o];
            ASSERT_TRUE(Space2d::Evaluate(observation, problem.poses[observation.pose], feature,
                                          &residual, nullptr, nullptr));
            if (kernel.Weight(residual.dot(observation.information * residual)) < 1.0)
              ++weighted_observations;
          }
        }
      }
    }
  }
  EXPECT_GE(features_checked, 20);
  // The kernel case compares something the kernel changes.
  if (robust) {
    EXPECT_GT(weighted_observations, 0);
  }
}

INSTANTIATE_TEST_SUITE_P(KindsAndKernels, FeatureLinearizerTest,
                         ::testing::Combine(::testing::Bool(), ::testing::Bool()));

}  // namespace
}  // namespace graphslam::core

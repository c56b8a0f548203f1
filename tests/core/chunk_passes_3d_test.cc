// The chunk passes on the 3-D space (6 x 6 pose blocks, 3-D points) against a
// dense reference: the full normal equations H = sum J^T W J, g = sum J^T W e
// assembled densely from the models' Jacobians (checked against numeric
// differences in se3_models_test), Schur-complemented densely with Eigen:
//   S   = H_xx - H_xm (H_mm + lambda D_m)^{-1} H_mx
//   rhs = -g_x + H_xm (H_mm + lambda D_m)^{-1} g_m
//   dm  = -(H_mm + lambda D_m)^{-1} (g_m + H_mx dx)
// where x holds the free poses and the kept features (padded to 6 by the
// reduced system) and m the eliminated features. Shares nothing with the
// feature linearizer, the Schur eliminator or the chunking under test.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <functional>
#include <tuple>
#include <vector>

#include "core/chunk_passes.h"
#include "core/gps_3d_model.h"
#include "core/point_3d_observation_model.h"
#include "core/pose_factors.h"
#include "core/relative_pose_3d_model.h"
#include "partition/ingest/in_memory_chunk_source.h"
#include "tests/testing/reduced_system_at.h"
#include "tests/testing/random_problem_3d.h"

namespace graphslam::core {
namespace {

constexpr double kTolerance = 1e-9;  // relative, on norms

struct DenseSystem {
  Eigen::MatrixXd h;  // [free poses (6 each, layout order); features (3 each)]
  Eigen::VectorXd g;
  double observations_chi2 = 0.0;
};

// The dense normal equations of `problem` at its state.
DenseSystem DenseNormalEquations(const Problem3d& problem, const UnknownLayout& layout,
                                 const RobustKernel& kernel) {
  const int np = layout.num_unknown_poses;
  const int n = 6 * np + 3 * problem.num_features();
  DenseSystem out;
  out.h.setZero(n, n);
  out.g.setZero(n);
  auto add = [&](const Eigen::MatrixXd& j, const Eigen::MatrixXd& w, const Eigen::VectorXd& e) {
    out.h += j.transpose() * w * j;
    out.g += j.transpose() * w * e;
  };
  auto pose_column = [&](int pose) { return 6 * layout.unknown_index[pose]; };
  for (const RelativePose3Constraint& c : problem.relative_poses) {
    Vector6d e;
    Matrix6d ja, jb;
    EvaluateRelativePose3(problem.poses[c.from], problem.poses[c.to], c.z, &e, &ja, &jb);
    Eigen::MatrixXd j = Eigen::MatrixXd::Zero(6, n);
    if (layout.unknown_index[c.from] >= 0) j.middleCols<6>(pose_column(c.from)) += ja;
    if (layout.unknown_index[c.to] >= 0) j.middleCols<6>(pose_column(c.to)) += jb;
    add(j, c.information, e);
  }
  for (const Gps3Constraint& c : problem.gps) {
    Eigen::Vector3d e;
    Eigen::Matrix<double, 3, 6> jp;
    EvaluateGps3(problem.poses[c.pose], c.z, &e, &jp);
    Eigen::MatrixXd j = Eigen::MatrixXd::Zero(3, n);
    if (layout.unknown_index[c.pose] >= 0) j.middleCols<6>(pose_column(c.pose)) = jp;
    add(j, c.information, e);
  }
  for (const Point3Observation& o : problem.observations) {
    Eigen::Vector3d e;
    Eigen::Matrix<double, 3, 6> jp;
    Eigen::Matrix3d jm;
    EvaluatePoint3Observation(problem.poses[o.pose], problem.features[o.feature], o.z, &e, &jp,
                              &jm);
    Eigen::MatrixXd j = Eigen::MatrixXd::Zero(3, n);
    if (layout.unknown_index[o.pose] >= 0) j.middleCols<6>(pose_column(o.pose)) = jp;
    j.middleCols<3>(6 * np + 3 * o.feature) = jm;
    const double squared = e.dot(o.information * e);
    out.observations_chi2 += kernel.Cost(squared);
    add(j, kernel.Weight(squared) * o.information, e);
  }
  return out;
}

// The dense reference of one reduce and recover, in the reduced system's
// layout (kept features padded to 6 with a unit pad).
struct DenseReduction {
  Eigen::MatrixXd s;
  Eigen::VectorXd rhs;
  Eigen::VectorXd gradient;  // unreduced g_x, padded like rhs
  // dm of every feature (3 each) for a reduced-system step `step`.
  std::function<Eigen::VectorXd(const Eigen::VectorXd&)> recover;
};

DenseReduction DenseReduce(const DenseSystem& dense, const UnknownLayout& layout,
                           int num_features, double lambda) {
  const int np = layout.num_unknown_poses;
  std::vector<int> x, m, padded;  // dense indices; padded index of each x entry
  for (int i = 0; i < 6 * np; ++i) {
    x.push_back(i);
    padded.push_back(i);
  }
  for (int f = 0; f < num_features; ++f) {
    for (int c = 0; c < 3; ++c) {
      if (layout.IsKept(f)) {
        x.push_back(6 * np + 3 * f + c);
        padded.push_back(6 * layout.feature_unknown_index[f] + c);
      } else {
        m.push_back(6 * np + 3 * f + c);
      }
    }
  }
  const Eigen::MatrixXd hxx = dense.h(x, x);
  const Eigen::MatrixXd hxm = dense.h(x, m);
  Eigen::MatrixXd hmm = dense.h(m, m);
  // D_m = clamp(diag C) per feature; H_mm is block diagonal, so its diagonal.
  const Eigen::VectorXd damping = hmm.diagonal().cwiseMax(kMinDiagonal).cwiseMin(kMaxDiagonal);
  hmm.diagonal() += lambda * damping;
  const Eigen::LDLT<Eigen::MatrixXd> hmm_ldlt(hmm);
  const Eigen::VectorXd gx = dense.g(x);
  const Eigen::VectorXd gm = dense.g(m);
  const Eigen::MatrixXd s = hxx - hxm * hmm_ldlt.solve(hxm.transpose());
  const Eigen::VectorXd rhs = -gx + hxm * hmm_ldlt.solve(gm);

  const int rows = 6 * layout.num_blocks();
  DenseReduction out;
  out.s = Eigen::MatrixXd::Zero(rows, rows);
  out.rhs = Eigen::VectorXd::Zero(rows);
  out.gradient = Eigen::VectorXd::Zero(rows);
  for (size_t a = 0; a < x.size(); ++a) {
    out.rhs[padded[a]] = rhs[a];
    out.gradient[padded[a]] = gx[a];
    for (size_t b = 0; b < x.size(); ++b) out.s(padded[a], padded[b]) = s(a, b);
  }
  for (int f = 0; f < num_features; ++f) {
    if (!layout.IsKept(f)) continue;
    for (int c = 3; c < 6; ++c) out.s(6 * layout.feature_unknown_index[f] + c,
                                      6 * layout.feature_unknown_index[f] + c) = 1.0;
  }
  out.recover = [=](const Eigen::VectorXd& step) {
    Eigen::VectorXd dx(x.size());
    for (size_t a = 0; a < x.size(); ++a) dx[a] = step[padded[a]];
    const Eigen::VectorXd eliminated = -hmm_ldlt.solve(gm + hxm.transpose() * dx);
    Eigen::VectorXd dm(3 * num_features);
    for (size_t a = 6 * np; a < x.size(); ++a) dm[x[a] - 6 * np] = dx[a];
    for (size_t a = 0; a < m.size(); ++a) dm[m[a] - 6 * np] = eliminated[a];
    return dm;
  };
  return out;
}

// (chunk size, kept features, Huber kernel, gps)
class ChunkPasses3dTest : public ::testing::TestWithParam<std::tuple<int, bool, bool, bool>> {};

TEST_P(ChunkPasses3dTest, ReduceAndRecoverEqualTheDenseSchurComplement) {
  const auto [chunk_size, keep, huber, gps] = GetParam();
  for (uint32_t seed = 1; seed <= 3; ++seed) {
    const Problem3d problem = testing::MakeRandomProblem3d(12, 7, gps, 100 + seed, nullptr,
                                                           nullptr, /*observations_per_feature=*/4);
    partition::ChunkingOptions chunking;
    chunking.max_observations_per_chunk = chunk_size;
    const partition::InMemoryChunkSource3d chunks(problem, chunking);
    UnknownLayout layout = UnknownLayout::FromProblem(problem);
    std::vector<uint8_t> kept(problem.features.size(), 0);
    if (keep) kept[0] = kept[3] = kept[6] = 1;
    layout.KeepFeatures(kept);
    PassContext3d context;
    context.chunks = &chunks;
    context.layout = &layout;
    if (huber) {
      context.kernel.type = RobustKernel::Type::kHuber;
      context.kernel.scale = 0.5;
    }
    const DenseSystem dense = DenseNormalEquations(problem, layout, context.kernel);
    for (const double lambda : {0.0, 0.3}) {
      const DenseReduction reference = DenseReduce(dense, layout, problem.num_features(), lambda);
      ReducedSystem system = testing::ReducedSystemAt(problem, context, problem.poses);
      ASSERT_TRUE(ReducePass(context, problem.poses, problem.features, lambda, &system).ok());
      const Eigen::MatrixXd s = system.matrix.ToDense();
      EXPECT_LE(testing::RelativeDifference(s, reference.s), kTolerance)
          << "seed " << seed << " lambda " << lambda << "\nchunked:\n" << s << "\ndense:\n"
          << reference.s;
      EXPECT_LE(testing::RelativeDifference(system.rhs, reference.rhs), kTolerance)
          << "seed " << seed << "\nchunked: " << system.rhs.transpose()
          << "\ndense:   " << reference.rhs.transpose();
      EXPECT_LE(testing::RelativeDifference(system.gradient, reference.gradient), kTolerance);
      EXPECT_NEAR(system.chi2, dense.observations_chi2, kTolerance * dense.observations_chi2);

      // Recovery for the reduced solution (an arbitrary step would do too).
      const Eigen::VectorXd step = reference.s.ldlt().solve(reference.rhs);
      std::vector<Point3> candidate;
      RecoveryResult recovery;
      ASSERT_TRUE(RecoverPass(context,
                              {problem.poses, problem.features, lambda, step, problem.poses},
                              &candidate, &recovery)
                      .ok());
      Eigen::VectorXd dm(3 * problem.num_features());
      for (int f = 0; f < problem.num_features(); ++f)
        dm.segment<3>(3 * f) = candidate[f] - problem.features[f];
      const Eigen::VectorXd dense_dm = reference.recover(step);
      // candidate - feature loses the digits of |feature| / |dm|: 1e-9 of
      // the features' scale.
      Eigen::VectorXd scale(problem.num_features());
      for (int f = 0; f < problem.num_features(); ++f) scale[f] = problem.features[f].norm();
      EXPECT_LE((dm - dense_dm).norm(), kTolerance * (dense_dm.norm() + scale.norm()))
          << "seed " << seed << "\nchunked: " << dm.transpose()
          << "\ndense:   " << dense_dm.transpose();
    }
  }
}

INSTANTIATE_TEST_SUITE_P(ChunkSizesKeptKernelsGps, ChunkPasses3dTest,
                         ::testing::Combine(::testing::Values(1, 7, 100000), ::testing::Bool(),
                                            ::testing::Bool(), ::testing::Bool()));

// The fused pass on 3-D chunks: its next system is ReducePass at the
// candidate bit for bit, and its recovery that of RecoverPass.
TEST(ChunkPasses3d, FusedPassEqualsReduceAtTheCandidateBitForBit) {
  for (const int chunk_size : {1, 9}) {
    const Problem3d problem = testing::MakeRandomProblem3d(14, 8, /*gps=*/true, 7, nullptr,
                                                           nullptr, 4);
    partition::ChunkingOptions chunking;
    chunking.max_observations_per_chunk = chunk_size;
    const partition::InMemoryChunkSource3d chunks(problem, chunking);
    UnknownLayout layout = UnknownLayout::FromProblem(problem);
    std::vector<uint8_t> kept(problem.features.size(), 0);
    kept[2] = 1;
    layout.KeepFeatures(kept);
    PassContext3d context;
    context.chunks = &chunks;
    context.layout = &layout;
    ReducedSystem system = testing::ReducedSystemAt(problem, context, problem.poses);
    ASSERT_TRUE(ReducePass(context, problem.poses, problem.features, 0.1, &system).ok());
    const Eigen::VectorXd step = system.matrix.ToDense().ldlt().solve(system.rhs);
    std::vector<Pose3> candidate_poses = problem.poses;
    for (int p = 0; p < problem.num_poses(); ++p) {
      const int u = layout.unknown_index[p];
      if (u >= 0) candidate_poses[p] = RetractPose3(problem.poses[p], step.segment<6>(6 * u));
    }
    std::vector<Point3> separate_features, fused_features;
    RecoveryResult separate, fused;
    ASSERT_TRUE(RecoverPass(context,
                            {problem.poses, problem.features, 0.1, step, candidate_poses},
                            &separate_features, &separate)
                    .ok());
    ReducedSystem next = testing::ReducedSystemAt(problem, context, candidate_poses);
    Status next_status;
    ASSERT_TRUE(RecoverAndReducePass(
                    context, {problem.poses, problem.features, 0.1, step, candidate_poses},
                    &fused_features, &fused, {0.05, &next, &next_status})
                    .ok());
    ASSERT_TRUE(next_status.ok()) << next_status.ToString();
    ReducedSystem expected = testing::ReducedSystemAt(problem, context, candidate_poses);
    ASSERT_TRUE(
        ReducePass(context, candidate_poses, separate_features, 0.05, &expected).ok());
    EXPECT_EQ(fused.candidate_chi2, separate.candidate_chi2);
    EXPECT_EQ(fused.gradient_dot_step, separate.gradient_dot_step);
    for (int f = 0; f < problem.num_features(); ++f)
      EXPECT_EQ(fused_features[f], separate_features[f]) << f;
    EXPECT_EQ((next.matrix.ToDense() - expected.matrix.ToDense()).norm(), 0.0);
    EXPECT_EQ((next.rhs - expected.rhs).norm(), 0.0);
    EXPECT_EQ((next.hessian_diagonal - expected.hessian_diagonal).norm(), 0.0);
    EXPECT_EQ(next.chi2, expected.chi2);
  }
}

}  // namespace
}  // namespace graphslam::core

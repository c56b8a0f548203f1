// Pose-only constraints (relative pose, velocity motion, GPS; 3-D relative
// pose and GPS) with robust kernels per constraint type: gradient and Gauss-Newton blocks against
// numeric differentiation of the robust cost, and whole solves where wrong
// loop closures or a GPS outlier pull the plain least-squares map away.
#include "core/pose_factors.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>
#include <type_traits>

#include "core/gps_3d_model.h"
#include "core/gps_model.h"
#include "core/graphslam_solver.h"
#include "core/interpolated_pose_range_bearing_model.h"
#include "core/pose_range_bearing_model.h"
#include "core/relative_pose_3d_model.h"
#include "core/relative_pose_model.h"
#include "core/velocity_motion_model.h"
#include "partition/ingest/in_memory_chunk_source.h"
#include "tests/testing/numeric_diff.h"
#include "tests/testing/random_problem.h"
#include "tests/testing/random_problem_3d.h"

namespace graphslam::core {
namespace {

RobustKernel Kernel(RobustKernel::Type type, double scale) {
  RobustKernel kernel;
  kernel.type = type;
  kernel.scale = scale;
  return kernel;
}

struct Linearization {
  Eigen::MatrixXd hessian;
  Eigen::VectorXd gradient;
  double chi2 = 0.0;
};

// Problem2d or Problem3d (pose blocks of 3 or 6).
template <class Problem>
Linearization Linearize(const Problem& problem, const UnknownLayout& layout,
                        const PoseFactorKernels& kernels) {
  constexpr int kPoseDim = std::is_same_v<typename Problem::Pose, Pose2> ? 3 : 6;
  std::vector<std::pair<int, int>> pairs;
  AppendPoseFactorPattern(problem, layout, &pairs);
  BlockSparseMatrix hessian =
      BlockSparseMatrix::FromPattern(kPoseDim, layout.num_unknown_poses, std::move(pairs));
  Eigen::VectorXd gradient = Eigen::VectorXd::Zero(hessian.num_rows());
  Eigen::VectorXd diagonal = Eigen::VectorXd::Zero(hessian.num_rows());
  Linearization out;
  out.chi2 =
      LinearizePoseFactors(problem, problem.poses, layout, &hessian, &gradient, &diagonal, kernels);
  out.hessian = hessian.ToDense();
  out.gradient = gradient;
  EXPECT_TRUE(diagonal.isApprox(out.hessian.diagonal()));
  return out;
}

// The poses of `problem` with every unknown pose moved by its block of `delta`
// (body-frame increments, core/se2.h RetractPose).
std::vector<Pose2> Retracted(const Problem2d& problem, const UnknownLayout& layout,
                             const Eigen::VectorXd& delta) {
  std::vector<Pose2> poses = problem.poses;
  for (int32_t p = 0; p < problem.num_poses(); ++p) {
    const int32_t u = layout.unknown_index[p];
    if (u >= 0) poses[p] = RetractPose(poses[p], delta.segment<3>(3 * u));
  }
  return poses;
}

// Only one constraint type carries a kernel at a time, so a wrong routing
// (say the GPS kernel applied to odometry) shows.
std::vector<PoseFactorKernels> KernelCases() {
  std::vector<PoseFactorKernels> cases(1);  // no kernel
  for (RobustKernel::Type type : {RobustKernel::Type::kHuber, RobustKernel::Type::kCauchy}) {
    PoseFactorKernels relative, motion, gps, all;
    relative.relative_pose = Kernel(type, 0.7);
    motion.motion = Kernel(type, 0.7);
    gps.gps = Kernel(type, 0.7);
    all.relative_pose = all.motion = all.gps = Kernel(type, 1.3);
    cases.insert(cases.end(), {relative, motion, gps, all});
  }
  return cases;
}

TEST(PoseFactors, RobustGradientIsHalfTheNumericDerivativeOfTheRobustCost) {
  for (bool velocity : {false, true}) {
    testing::RandomProblemOptions options;
    options.num_poses = 12;
    options.num_features = 0;
    options.velocity_motion = velocity;
    options.gps_every = 3;
    options.seed = 5;
    const Problem2d problem = testing::MakeRandomProblem(options).problem;  // perturbed guess
    const UnknownLayout layout = UnknownLayout::FromProblem(problem);
    for (const PoseFactorKernels& kernels : KernelCases()) {
      const Linearization lin = Linearize(problem, layout, kernels);
      EXPECT_DOUBLE_EQ(lin.chi2, PoseFactorsChi2(problem, problem.poses, kernels));
      // d rho_total / d delta = 2 g (chi2 = sum rho(e^T W e), g = sum rho' J^T W e).
      const Eigen::VectorXd zero = Eigen::VectorXd::Zero(lin.gradient.size());
      const Eigen::MatrixXd numeric = testing::NumericJacobian(
          [&](const Eigen::VectorXd& delta) {
            return Eigen::VectorXd::Constant(
                1, PoseFactorsChi2(problem, Retracted(problem, layout, delta), kernels));
          },
          zero, 1e-6);
      const Eigen::VectorXd expected = 0.5 * numeric.transpose();
      EXPECT_LT((lin.gradient - expected).norm(), 1e-5 * std::max(1.0, expected.norm()))
          << "velocity " << velocity << " kernels "
          << RobustKernelsName(RobustKernel(), kernels);
    }
  }
}

// The 3-D factors go through the same template: chi2 and the gradient agree with the robust cost, differentiated numerically
// w.r.t. the body-frame increments (x Exp(d)).
TEST(PoseFactors, ThreeDimensionalGradientIsHalfTheNumericDerivativeOfTheRobustCost) {
  const Problem3d problem = testing::MakeRandomProblem3d(8, 0, /*gps=*/true, 11);
  ASSERT_FALSE(problem.gps.empty());
  const UnknownLayout layout = UnknownLayout::FromProblem(problem);
  for (const PoseFactorKernels& kernels : KernelCases()) {
    const Linearization lin = Linearize(problem, layout, kernels);
    EXPECT_GT(lin.chi2, 0.0);
    EXPECT_DOUBLE_EQ(lin.chi2, PoseFactorsChi2(problem, problem.poses, kernels));
    const auto cost = [&](const Eigen::VectorXd& delta) {
      std::vector<Pose3> poses = problem.poses;
      for (int32_t p = 0; p < problem.num_poses(); ++p) {
        const int32_t u = layout.unknown_index[p];
        if (u >= 0) poses[p] = RetractPose3(poses[p], delta.segment<6>(6 * u));
      }
      return Eigen::VectorXd::Constant(1, PoseFactorsChi2(problem, poses, kernels));
    };
    const Eigen::VectorXd expected =
        0.5 * testing::NumericJacobian(cost, Eigen::VectorXd::Zero(lin.gradient.size()), 1e-6)
                  .transpose();
    EXPECT_LT((lin.gradient - expected).norm(), 1e-5 * std::max(1.0, expected.norm()))
        << RobustKernelsName(RobustKernel(), kernels);
  }
}

// The planar relative poses' blocks come from products of their Jacobians'
// pieces (core/pose_factors.cc): H and g against sum rho'(s) A^T W A and
// A^T W e with A the dense Jacobians of EvaluateRelativePoseIncrement, with a
// correlated information matrix, edges both ways and to an anchored pose.
TEST(PoseFactors, PlanarRelativePoseBlocksAreTheWeightedGaussNewtonSums) {
  Problem2d problem;
  for (int i = 0; i < 6; ++i)
    problem.AddPose(i, Pose2(0.9 * i + 0.1 * i * i, 0.4 * std::sin(i), 0.5 * i - 1.0), true, 0);
  problem.pose_fixed[2] = 1;
  Eigen::Matrix3d information;
  information << 30.0, 4.0, -2.0, 4.0, 20.0, 3.0, -2.0, 3.0, 200.0;
  const std::vector<std::pair<int, int>> edges = {{0, 1}, {1, 2}, {2, 3}, {3, 4},
                                                  {4, 5}, {5, 1}, {4, 0}, {3, 2}};
  for (const auto& [from, to] : edges) {
    problem.relative_poses.push_back(RelativePoseConstraint{
        from, to, Pose2(0.8, 0.1 * from - 0.2, 0.4 + 0.1 * to), information, 0});
  }
  const UnknownLayout layout = UnknownLayout::FromProblem(problem);
  ASSERT_EQ(layout.num_unknown_poses, 5);
  for (const PoseFactorKernels& kernels : KernelCases()) {
    const Linearization lin = Linearize(problem, layout, kernels);
    Eigen::MatrixXd expected_h = Eigen::MatrixXd::Zero(15, 15);
    Eigen::VectorXd expected_g = Eigen::VectorXd::Zero(15);
    for (const RelativePoseConstraint& c : problem.relative_poses) {
      Eigen::Vector3d e;
      Eigen::Matrix3d j[2];
      EvaluateRelativePoseIncrement(problem.poses[c.from], problem.poses[c.to], c.z, &e, &j[0],
                                    &j[1]);
      const Eigen::Matrix3d w =
          kernels.relative_pose.Weight(e.dot(c.information * e)) * c.information;
      const int32_t u[2] = {layout.unknown_index[c.from], layout.unknown_index[c.to]};
      for (int a = 0; a < 2; ++a) {
        if (u[a] < 0) continue;
        expected_g.segment<3>(3 * u[a]) += j[a].transpose() * w * e;
        for (int b = 0; b < 2; ++b) {
          if (u[b] >= 0) expected_h.block<3, 3>(3 * u[a], 3 * u[b]) += j[a].transpose() * w * j[b];
        }
      }
    }
    EXPECT_LT((lin.hessian - expected_h).norm(), 1e-12 * expected_h.norm())
        << RobustKernelsName(RobustKernel(), kernels);
    EXPECT_LT((lin.gradient - expected_g).norm(), 1e-12 * expected_g.norm())
        << RobustKernelsName(RobustKernel(), kernels);
  }
}

// The 3-D relative poses' blocks come from products of their Jacobians'
// factors (core/pose_factors_3d.cc): H and g against sum rho'(s) A^T W A and
// A^T W e with A the dense Jacobians EvaluateRelativePose3 gives, with edges
// both ways (i < j and i > j), edges to an anchored pose, and kernels.
TEST(PoseFactors, ThreeDimensionalBlocksAreTheWeightedGaussNewtonSums) {
  Problem3d problem = testing::MakeRandomProblem3d(9, 0, /*gps=*/true, 23);
  problem.pose_fixed[0] = 1;
  problem.pose_fixed[4] = 1;
  RelativePose3Constraint backwards = problem.relative_poses[5];  // 5 -> 6
  std::swap(backwards.from, backwards.to);
  backwards.z = Inverse(backwards.z);
  problem.relative_poses.push_back(backwards);
  const UnknownLayout layout = UnknownLayout::FromProblem(problem);
  ASSERT_EQ(layout.num_unknown_poses, problem.num_poses() - 2);  // pose 0 and 4 anchored
  int descending = 0, anchored = 0;
  for (const RelativePose3Constraint& c : problem.relative_poses) {
    descending += c.from > c.to;
    anchored += layout.unknown_index[c.from] < 0 || layout.unknown_index[c.to] < 0;
  }
  ASSERT_GE(descending, 2);
  ASSERT_GE(anchored, 3);
  for (const PoseFactorKernels& kernels : KernelCases()) {
    const Linearization lin = Linearize(problem, layout, kernels);
    const int n = 6 * layout.num_unknown_poses;
    Eigen::MatrixXd expected_h = Eigen::MatrixXd::Zero(n, n);
    Eigen::VectorXd expected_g = Eigen::VectorXd::Zero(n);
    const auto add = [&](const std::vector<int32_t>& poses, const Eigen::MatrixXd& jacobian,
                         const Eigen::MatrixXd& information, const Eigen::VectorXd& e,
                         const RobustKernel& kernel) {
      const Eigen::MatrixXd w = kernel.Weight(e.dot(information * e)) * information;
      for (size_t a = 0; a < poses.size(); ++a) {
        const int32_t ua = layout.unknown_index[poses[a]];
        if (ua < 0) continue;
        const Eigen::MatrixXd ja = jacobian.middleCols(6 * a, 6);
        expected_g.segment<6>(6 * ua) += ja.transpose() * w * e;
        for (size_t b = 0; b < poses.size(); ++b) {
          const int32_t ub = layout.unknown_index[poses[b]];
          if (ub < 0) continue;
          expected_h.block<6, 6>(6 * ua, 6 * ub) +=
              ja.transpose() * w * jacobian.middleCols(6 * b, 6);
        }
      }
    };
    for (const RelativePose3Constraint& c : problem.relative_poses) {
      Vector6d e;
      Matrix6d ji, jj;
      EvaluateRelativePose3(problem.poses[c.from], problem.poses[c.to], c.z, &e, &ji, &jj);
      Eigen::MatrixXd jacobian(6, 12);
      jacobian << ji, jj;
      add({c.from, c.to}, jacobian, c.information, e, kernels.relative_pose);
    }
    for (const Gps3Constraint& c : problem.gps) {
      Eigen::Vector3d e;
      Eigen::Matrix<double, 3, 6> j;
      EvaluateGps3(problem.poses[c.pose], c.z, &e, &j);
      add({c.pose}, j, c.information, e, kernels.gps);
    }
    EXPECT_LT((lin.hessian - expected_h).norm(), 1e-12 * expected_h.norm())
        << RobustKernelsName(RobustKernel(), kernels);
    EXPECT_LT((lin.gradient - expected_g).norm(), 1e-12 * expected_g.norm())
        << RobustKernelsName(RobustKernel(), kernels);
  }
}

// H = sum rho'(s) A^T W A with A the numeric Jacobian of the residual w.r.t.
// the increments, checked constraint by constraint (one at a time).
TEST(PoseFactors, RobustHessianIsTheWeightedGaussNewtonBlock) {
  const Pose2 a(1.0, -2.0, 0.3), b(2.5, -1.0, 1.4);
  const Eigen::Matrix3d w3 = Eigen::Vector3d(20.0, 30.0, 400.0).asDiagonal();
  const Eigen::Matrix2d w2 = Eigen::Vector2d(4.0, 2.0).asDiagonal();
  for (int type = 0; type < 3; ++type) {
    Problem2d problem;
    problem.AddPose(0, a, true, 0);
    problem.AddPose(1, b, true, 0);
    // Residual of the one constraint as a function of both increments.
    std::function<Eigen::VectorXd(const std::vector<Pose2>&)> residual;
    Eigen::MatrixXd information;
    if (type == 0) {
      RelativePoseConstraint c{0, 1, Pose2(1.0, 0.5, 0.9), w3, 0};
      problem.relative_poses.push_back(c);
      residual = [c](const std::vector<Pose2>& x) {
        Eigen::Vector3d e;
        EvaluateRelativePose(x[0], x[1], c.z, &e, nullptr, nullptr);
        return Eigen::VectorXd(e);
      };
      information = w3;
    } else if (type == 1) {
      VelocityMotionConstraint c;
      c.from = 0;
      c.to = 1;
      c.control = VelocityControl{1.2, 0.4, 1.0};
      c.information = w3;
      problem.motions.push_back(c);
      residual = [c](const std::vector<Pose2>& x) {
        Eigen::Vector3d e;
        EvaluateVelocityMotion(x[0], x[1], c.control, &e, nullptr, nullptr);
        return Eigen::VectorXd(e);
      };
      information = w3;
    } else {
      GpsConstraint c{1, Eigen::Vector2d(3.5, 0.0), w2, 0};
      problem.gps.push_back(c);
      residual = [c](const std::vector<Pose2>& x) {
        Eigen::Vector2d e;
        EvaluateGps(x[1], c.z, &e, nullptr);
        return Eigen::VectorXd(e);
      };
      information = w2;
    }
    problem.pose_fixed[0] = 1;  // one anchored pose, one unknown (GPS too)
    const UnknownLayout layout = UnknownLayout::FromProblem(problem);
    ASSERT_EQ(layout.num_unknown_poses, 1);
    const Eigen::MatrixXd jacobian = testing::NumericJacobian(
        [&](const Eigen::VectorXd& delta) {
          return residual(Retracted(problem, layout, delta));
        },
        Eigen::VectorXd::Zero(3));
    const Eigen::VectorXd e = residual(problem.poses);
    const double s = e.dot(information * e);
    ASSERT_GT(s, 4.0) << "the constraint must sit in the robust region";
    for (RobustKernel::Type kernel_type :
         {RobustKernel::Type::kNone, RobustKernel::Type::kHuber, RobustKernel::Type::kCauchy}) {
      const RobustKernel kernel = Kernel(kernel_type, 1.5);
      PoseFactorKernels kernels;
      (type == 0 ? kernels.relative_pose : type == 1 ? kernels.motion : kernels.gps) = kernel;
      const Linearization lin = Linearize(problem, layout, kernels);
      const Eigen::MatrixXd expected =
          kernel.Weight(s) * jacobian.transpose() * information * jacobian;
      EXPECT_LT((lin.hessian - expected).norm(), 1e-6 * expected.norm())
          << "constraint type " << type << " " << RobustKernelName(kernel);
      EXPECT_NEAR(lin.chi2, kernel.Cost(s), 1e-12 * s);
    }
  }
}

// Robot-to-robot range-bearing constraints (pose_range_bearings) between
// unknown poses and to the anchor, two-pose ones and ones interpolated between
// two poses of the observed robot (three-pose factors, alpha in (0, 1)):
// gradient against the numeric derivative of the (robust) cost, and
// H = sum rho'(s) A^T W A with A the numeric Jacobian of the stacked residuals
// w.r.t. the body-frame increments of all poses.
TEST(PoseFactors, RobotSightingMatchesNumericDifferentiation) {
  Problem2d problem;
  problem.AddPose(0, Pose2(0.0, 0.0, 0.2), true, 0);
  problem.AddPose(1, Pose2(3.0, 1.0, 2.8), true, 0);
  problem.AddPose(2, Pose2(-1.0, 4.0, -1.9), true, 0);
  problem.AddPose(3, Pose2(-0.5, 4.6, -1.7), true, 0);
  problem.pose_fixed[0] = 1;
  const Eigen::Matrix2d w = Eigen::Vector2d(100.0, 400.0).asDiagonal();
  // (from, to, z, information, line[, to_next, alpha])
  problem.pose_range_bearings = {{1, 2, Eigen::Vector2d(4.9, 1.2), w, 0},
                                 {2, 1, Eigen::Vector2d(5.1, -2.3), w, 0},
                                 {0, 1, Eigen::Vector2d(3.3, 0.05), w, 0},
                                 {1, 2, Eigen::Vector2d(4.7, 1.3), w, 0, 3, 0.3},
                                 {0, 2, Eigen::Vector2d(4.0, 1.0), w, 0, 3, 0.9},
                                 {2, 0, Eigen::Vector2d(4.2, 1.5), w, 0, 1, 0.5}};
  const UnknownLayout layout = UnknownLayout::FromProblem(problem);
  ASSERT_EQ(layout.num_unknown_poses, 3);
  const auto count = static_cast<Eigen::Index>(problem.pose_range_bearings.size());
  const auto residuals = [&](const std::vector<Pose2>& x) {
    Eigen::VectorXd e(2 * count);
    for (Eigen::Index k = 0; k < count; ++k) {
      const PoseRangeBearingConstraint& c = problem.pose_range_bearings[static_cast<size_t>(k)];
      Eigen::Vector2d ek;
      EXPECT_TRUE(c.interpolated()
                      ? EvaluateInterpolatedPoseRangeBearing(x[c.from], x[c.to], x[c.to_next],
                                                             c.alpha, c.z, &ek, nullptr, nullptr,
                                                             nullptr)
                      : EvaluatePoseRangeBearing(x[c.from], x[c.to], c.z, &ek, nullptr, nullptr));
      e.segment<2>(2 * k) = ek;
    }
    return e;
  };
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(9);
  const Eigen::MatrixXd jacobian = testing::NumericJacobian(
      [&](const Eigen::VectorXd& delta) { return residuals(Retracted(problem, layout, delta)); },
      zero);
  const Eigen::VectorXd e = residuals(problem.poses);
  for (RobustKernel::Type type :
       {RobustKernel::Type::kNone, RobustKernel::Type::kHuber, RobustKernel::Type::kCauchy}) {
    PoseFactorKernels kernels;
    kernels.robot = Kernel(type, 1.5);
    const Linearization lin = Linearize(problem, layout, kernels);
    Eigen::MatrixXd expected = Eigen::MatrixXd::Zero(9, 9);
    double cost = 0.0;
    for (Eigen::Index k = 0; k < count; ++k) {
      const Eigen::Vector2d ek = e.segment<2>(2 * k);
      const double s = ek.dot(w * ek);
      cost += kernels.robot.Cost(s);
      const Eigen::MatrixXd a = jacobian.middleRows(2 * k, 2);
      expected += kernels.robot.Weight(s) * a.transpose() * w * a;
    }
    EXPECT_NEAR(lin.chi2, cost, 1e-9 * cost);
    EXPECT_LT((lin.hessian - expected).norm(), 1e-6 * expected.norm()) << RobustKernelName(kernels.robot);
    const Eigen::MatrixXd numeric = testing::NumericJacobian(
        [&](const Eigen::VectorXd& delta) {
          return Eigen::VectorXd::Constant(
              1, PoseFactorsChi2(problem, Retracted(problem, layout, delta), kernels));
        },
        zero, 1e-6);
    const Eigen::VectorXd gradient = 0.5 * numeric.transpose();
    EXPECT_LT((lin.gradient - gradient).norm(), 1e-5 * std::max(1.0, gradient.norm()))
        << RobustKernelName(kernels.robot);
  }
}

// A kernel whose scale is never reached is rho(s) = s, rho' = 1 exactly: the
// linearization is bit for bit the plain one (and the plain one is the
// default, so solves without kernels are unchanged).
TEST(PoseFactors, UnreachedKernelIsBitForBitThePlainLinearization) {
  testing::RandomProblemOptions options;
  options.num_poses = 15;
  options.num_features = 0;
  options.gps_every = 4;
  const Problem2d problem = testing::MakeRandomProblem(options).problem;
  const UnknownLayout layout = UnknownLayout::FromProblem(problem);
  PoseFactorKernels huge;
  huge.relative_pose = huge.motion = huge.gps = Kernel(RobustKernel::Type::kHuber, 1e8);
  const Linearization plain = Linearize(problem, layout, PoseFactorKernels());
  const Linearization robust = Linearize(problem, layout, huge);
  EXPECT_EQ(plain.chi2, robust.chi2);
  EXPECT_TRUE((plain.gradient.array() == robust.gradient.array()).all());
  EXPECT_TRUE((plain.hessian.array() == robust.hessian.array()).all());
}

// A robot drives a serpentine over a 6 x 10 grid (1 m spacing); loop closures
// join each pose to its neighbour in the next row. Three closures are wrong
// (a place-recognition false positive: 4 m and 1 rad off).
struct PoseGraph {
  Problem2d problem;
  std::vector<Pose2> truth;
};

PoseGraph SerpentineWithWrongClosures(int num_wrong) {
  const int rows = 6, columns = 10;
  std::mt19937 rng(3);
  std::normal_distribution<double> normal(0.0, 1.0);
  PoseGraph graph;
  auto index = [&](int r, int c) { return r * columns + (r % 2 == 0 ? c : columns - 1 - c); };
  graph.truth.resize(rows * columns);
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < columns; ++c) {
      const bool row_end = (r % 2 == 0) ? c == columns - 1 : c == 0;
      graph.truth[index(r, c)] =
          Pose2(c, r, row_end ? std::numbers::pi / 2 : (r % 2 == 0 ? 0.0 : std::numbers::pi));
    }
  }
  const Eigen::Vector3d sigma(0.03, 0.03, 0.01);
  const Eigen::Matrix3d information = sigma.cwiseInverse().cwiseAbs2().asDiagonal();
  auto measure = [&](int from, int to) {
    RelativePoseConstraint c;
    c.from = from;
    c.to = to;
    c.z = Between(graph.truth[from], graph.truth[to]) +
          Pose2(sigma.x() * normal(rng), sigma.y() * normal(rng), sigma.z() * normal(rng));
    c.information = information;
    return c;
  };
  Problem2d& p = graph.problem;
  p.source = "serpentine";
  for (int i = 0; i < rows * columns; ++i) p.AddPose(i, Pose2::Zero(), true, 0);
  for (int i = 0; i + 1 < rows * columns; ++i) p.relative_poses.push_back(measure(i, i + 1));
  // The initial guess chains the odometry from the true first pose.
  p.poses[0] = graph.truth[0];
  for (int i = 0; i + 1 < rows * columns; ++i)
    p.poses[i + 1] = Compose(p.poses[i], p.relative_poses[i].z);
  int wrong = 0;
  for (int r = 0; r + 1 < rows; ++r) {
    for (int c = 0; c < columns; c += 2) {
      const int from = index(r, c), to = index(r + 1, c);
      if (to == from + 1) continue;
      RelativePoseConstraint closure = measure(from, to);
      if (wrong < num_wrong && c == 4 + 2 * (r % 2)) {
        closure.z += Pose2(4.0, -3.0, 1.0);
        ++wrong;
      }
      p.relative_poses.push_back(closure);
    }
  }
  EXPECT_EQ(wrong, num_wrong);
  return graph;
}

double MaxPositionError(const std::vector<Pose2>& poses, const std::vector<Pose2>& truth) {
  double worst = 0.0;
  for (size_t i = 0; i < poses.size(); ++i)
    worst = std::max(worst, (poses[i].head<2>() - truth[i].head<2>()).norm());
  return worst;
}

std::vector<Pose2> SolvePoses(Problem2d problem, const PoseFactorKernels& kernels,
                              SolverSummary* summary) {
  partition::InMemoryChunkSource chunks(problem, partition::ChunkingOptions());
  SolverOptions options;
  options.pose_kernels = kernels;
  options.max_iterations = 100;
  Status status = SolveGraphSlam(options, chunks, &problem, summary);
  EXPECT_TRUE(status.ok()) << status.ToString();
  return problem.poses;
}

TEST(PoseFactors, OdometryKernelHoldsThePoseGraphAgainstWrongLoopClosures) {
  const PoseGraph clean = SerpentineWithWrongClosures(0);
  SolverSummary summary;
  const double clean_error =
      MaxPositionError(SolvePoses(clean.problem, PoseFactorKernels(), &summary), clean.truth);
  EXPECT_LT(clean_error, 0.2);

  const PoseGraph corrupted = SerpentineWithWrongClosures(3);
  const double plain_error =
      MaxPositionError(SolvePoses(corrupted.problem, PoseFactorKernels(), &summary), corrupted.truth);
  EXPECT_GT(plain_error, 1.0) << "the wrong closures must pull the plain solve away";
  for (const char* option : {"odometry=huber:1.5", "odometry=cauchy:1"}) {
    RobustKernel observation;
    PoseFactorKernels kernels;
    ASSERT_TRUE(ApplyRobustKernelOption(option, &observation, &kernels).ok());
    const double robust_error =
        MaxPositionError(SolvePoses(corrupted.problem, kernels, &summary), corrupted.truth);
    EXPECT_TRUE(summary.converged) << option << ": " << summary.termination;
    EXPECT_LT(robust_error, 0.25 * plain_error) << option << " plain " << plain_error;
    if (std::string(option).find("cauchy") != std::string::npos) {
      EXPECT_LT(robust_error, 2.0 * clean_error + 0.05) << option;
    }
  }
}

// A 40-pose loop (radius 5 m) with a GPS fix (sigma 0.5 m) at every pose; the
// fix at pose 20 is 63 m off (multipath).
TEST(PoseFactors, GpsKernelHoldsThePathAgainstAnOutlierFix) {
  testing::RandomProblemOptions options;
  options.num_poses = 40;
  options.num_features = 0;
  options.gps_every = 1;
  options.perturb_initial = false;
  options.seed = 7;
  testing::RandomProblem random = testing::MakeRandomProblem(options);
  Problem2d& problem = random.problem;
  ASSERT_EQ(problem.gps.size(), 40u);
  auto solve = [&](const PoseFactorKernels& kernels) {
    SolverSummary summary;
    const std::vector<Pose2> poses = SolvePoses(problem, kernels, &summary);
    EXPECT_TRUE(summary.converged) << summary.termination;
    return poses;
  };
  // The least-squares map without the outlier is the reference.
  const std::vector<Pose2> clean = solve(PoseFactorKernels());
  EXPECT_LT(MaxPositionError(clean, random.true_poses), 0.6);
  problem.gps[20].z += Eigen::Vector2d(60.0, -20.0);
  const double plain = MaxPositionError(solve(PoseFactorKernels()), clean);
  EXPECT_GT(plain, 1.0);
  for (const char* option : {"gps=huber:2", "gps=cauchy:1"}) {
    RobustKernel observation;
    PoseFactorKernels kernels;
    ASSERT_TRUE(ApplyRobustKernelOption(option, &observation, &kernels).ok());
    const double robust = MaxPositionError(solve(kernels), clean);
    EXPECT_LT(robust, 0.1 * plain) << option << " plain " << plain;
  }
  // The kernel on the other types leaves the GPS outlier pulling.
  PoseFactorKernels odometry_only;
  odometry_only.relative_pose = Kernel(RobustKernel::Type::kCauchy, 1.0);
  EXPECT_GT(MaxPositionError(solve(odometry_only), clean), 0.5 * plain);
}

}  // namespace
}  // namespace graphslam::core

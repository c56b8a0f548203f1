// SolveGraphSlam3d against a dense Gauss-Newton reference on small random
// problems (poses, 3-D points, relative poses, GPS). The reference stacks the
// whitened residuals r = L^T e (W = L L^T) and differentiates them by central
// differences through x Exp(d), so it shares nothing with the analytic
// Jacobians, the Schur elimination or the sparse solvers under test.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <random>

#include "core/graphslam_solver_3d.h"
#include "core/initialization_3d.h"
#include "core/point3_observation_model.h"
#include "core/relative_pose3_model.h"
#include "core/gps3_model.h"
#include "core/robust_kernel.h"
#include "tests/testing/numeric_diff.h"

namespace graphslam::core {
namespace {

Vector6d Noise6(std::mt19937& rng, double sigma_t, double sigma_r) {
  std::normal_distribution<double> n(0.0, 1.0);
  Vector6d d;
  for (int i = 0; i < 3; ++i) d[i] = sigma_t * n(rng);
  for (int i = 3; i < 6; ++i) d[i] = sigma_r * n(rng);
  return d;
}

// A loop of `n` poses on a helix with loop closures, `m` points observed from
// nearby poses, optional GPS on every pose; initial guess perturbed.
// *true_points and *true_poses (optional) receive the noise-free state.
Problem3d RandomProblem(int n, int m, bool gps, uint32_t seed,
                        std::vector<Point3>* true_points = nullptr,
                        std::vector<Pose3>* true_poses = nullptr) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::vector<Pose3> truth(n);
  for (int i = 0; i < n; ++i) {
    const double a = 2.0 * M_PI * i / n;
    truth[i].t = Eigen::Vector3d(4 * std::cos(a), 4 * std::sin(a), 0.3 * i);
    truth[i].q = ExpSO3(Eigen::Vector3d(0.1 * std::sin(a), 0.2, a + 0.5));
  }
  if (true_poses != nullptr) *true_poses = truth;
  Problem3d p;
  p.source = "random.g2o";
  for (int i = 0; i < n; ++i)
    p.AddPose(i, RetractPose3(truth[i], Noise6(rng, 0.3, 0.1)), true, 0);
  p.poses[0] = truth[0];
  Matrix6d info = Matrix6d::Identity();
  info.topLeftCorner<3, 3>() *= 50.0;
  info.bottomRightCorner<3, 3>() *= 400.0;
  info(0, 4) = info(4, 0) = 2.0;  // some correlation
  auto add_edge = [&](int i, int j) {
    RelativePose3Constraint c;
    c.from = i;
    c.to = j;
    c.z = RetractPose3(Between(truth[i], truth[j]), Noise6(rng, 0.05, 0.02));
    c.information = info;
    p.relative_poses.push_back(c);
  };
  for (int i = 0; i + 1 < n; ++i) add_edge(i, i + 1);
  add_edge(n - 1, 0);
  add_edge(2, n / 2);
  for (int f = 0; f < m; ++f) {
    const Point3 point(5 * normal(rng), 5 * normal(rng), 2 * normal(rng));
    if (true_points != nullptr) true_points->push_back(point);
    p.AddFeature(100 + f, point + Eigen::Vector3d(0.3, -0.2, 0.1), true);
    for (int k = 0; k < 3; ++k) {
      Point3Observation o;
      o.pose = (f * 3 + k * 2) % n;
      o.feature = f;
      o.z = InverseTransformPoint(truth[o.pose], point) + 0.02 * Eigen::Vector3d(normal(rng), normal(rng), normal(rng));
      o.information = Eigen::Matrix3d::Identity() * 100.0;
      o.information(0, 1) = o.information(1, 0) = 10.0;
      p.observations.push_back(o);
    }
  }
  if (gps) {
    for (int i = 0; i < n; ++i) {
      Gps3Constraint g;
      g.pose = i;
      g.z = truth[i].t + 0.1 * Eigen::Vector3d(normal(rng), normal(rng), normal(rng));
      g.information = Eigen::Matrix3d::Identity() * 10.0;
      p.gps.push_back(g);
    }
  }
  return p;
}

// Dense Gauss-Newton on the whitened residuals with numeric Jacobians.
class DenseReference3d {
 public:
  explicit DenseReference3d(const Problem3d& problem) : problem_(problem) {
    anchored_ = problem.gps.empty();  // pose 0 fixed, as the solver does
    first_ = anchored_ ? 1 : 0;
  }
  int Dimension() const {
    return 6 * (problem_.num_poses() - first_) + 3 * problem_.num_features();
  }
  void Apply(const Eigen::VectorXd& s, std::vector<Pose3>* poses, std::vector<Point3>* points) const {
    int k = 0;
    for (int i = first_; i < problem_.num_poses(); ++i, k += 6)
      (*poses)[i] = RetractPose3((*poses)[i], s.segment<6>(k));
    for (int f = 0; f < problem_.num_features(); ++f, k += 3) (*points)[f] += s.segment<3>(k);
  }
  Eigen::VectorXd Residual(const std::vector<Pose3>& poses, const std::vector<Point3>& points) const {
    std::vector<double> r;
    for (const auto& c : problem_.relative_poses) {
      Vector6d e;
      EvaluateRelativePose3(poses[c.from], poses[c.to], c.z, &e, nullptr, nullptr);
      const Matrix6d l = c.information.llt().matrixL();
      const Vector6d w = l.transpose() * e;
      r.insert(r.end(), w.data(), w.data() + 6);
    }
    for (const auto& o : problem_.observations) {
      Eigen::Vector3d e;
      EvaluatePoint3Observation(poses[o.pose], points[o.feature], o.z, &e, nullptr, nullptr);
      const Eigen::Matrix3d l = o.information.llt().matrixL();
      const Eigen::Vector3d w = l.transpose() * e;
      r.insert(r.end(), w.data(), w.data() + 3);
    }
    for (const auto& g : problem_.gps) {
      Eigen::Vector3d e;
      EvaluateGps3(poses[g.pose], g.z, &e, nullptr);
      const Eigen::Matrix3d l = g.information.llt().matrixL();
      const Eigen::Vector3d w = l.transpose() * e;
      r.insert(r.end(), w.data(), w.data() + 3);
    }
    return Eigen::Map<Eigen::VectorXd>(r.data(), static_cast<int>(r.size()));
  }
  // Runs `iterations` Gauss-Newton steps from the problem's state.
  double Solve(int iterations, std::vector<Pose3>* poses, std::vector<Point3>* points) const {
    *poses = problem_.poses;
    *points = problem_.features;
    for (int it = 0; it < iterations; ++it) {
      auto f = [&](const Eigen::VectorXd& s) -> Eigen::VectorXd {
        std::vector<Pose3> p = *poses;
        std::vector<Point3> m = *points;
        Apply(s, &p, &m);
        return Residual(p, m);
      };
      const Eigen::VectorXd zero = Eigen::VectorXd::Zero(Dimension());
      const Eigen::MatrixXd j = testing::NumericJacobian(f, zero);
      const Eigen::VectorXd r = f(zero);
      const Eigen::VectorXd step = (j.transpose() * j).ldlt().solve(-j.transpose() * r);
      Apply(step, poses, points);
    }
    return Residual(*poses, *points).squaredNorm();
  }

 private:
  const Problem3d& problem_;
  bool anchored_ = true;
  int first_ = 1;
};

void ExpectMatchesDenseReference(const Problem3d& input, LinearSolverType type) {
  Problem3d problem = input;
  std::vector<Pose3> ref_poses;
  std::vector<Point3> ref_points;
  const double ref_chi2 = DenseReference3d(input).Solve(15, &ref_poses, &ref_points);

  SolverOptions options;
  options.linear_solver = type;
  options.function_tolerance = 1e-14;
  options.parameter_tolerance = 1e-14;
  options.gradient_tolerance = 1e-12;
  SolverSummary summary;
  ASSERT_TRUE(SolveGraphSlam3d(options, &problem, &summary).ok());
  EXPECT_TRUE(summary.converged) << summary.termination;
  EXPECT_LT(summary.final_chi2, summary.initial_chi2);
  EXPECT_NEAR(summary.final_chi2, ref_chi2, 1e-8 * ref_chi2);
  EXPECT_NEAR(summary.final_chi2, Chi2Of3d(problem, problem.poses, problem.features), 1e-9);
  for (int i = 0; i < problem.num_poses(); ++i) {
    EXPECT_LT((problem.poses[i].t - ref_poses[i].t).norm(), 1e-6) << "pose " << i;
    EXPECT_LT(LogSO3(problem.poses[i].q.conjugate() * ref_poses[i].q).norm(), 1e-6);
  }
  for (int f = 0; f < problem.num_features(); ++f)
    EXPECT_LT((problem.features[f] - ref_points[f]).norm(), 1e-6) << "feature " << f;
}

TEST(GraphSlamSolver3d, PosesAndPointsMatchDenseGaussNewtonWithCholmod) {
  ExpectMatchesDenseReference(RandomProblem(12, 6, /*gps=*/false, 11), LinearSolverType::kCholmod);
}

TEST(GraphSlamSolver3d, PosesAndPointsMatchDenseGaussNewtonWithPcg) {
  ExpectMatchesDenseReference(RandomProblem(12, 6, /*gps=*/false, 12), LinearSolverType::kPcg);
}

TEST(GraphSlamSolver3d, GpsAnchoredProblemMatchesDenseGaussNewton) {
  ExpectMatchesDenseReference(RandomProblem(10, 4, /*gps=*/true, 13), LinearSolverType::kCholmod);
}

TEST(GraphSlamSolver3d, AnchorPoseDoesNotMove) {
  Problem3d problem = RandomProblem(10, 3, false, 14);
  const Pose3 anchor = problem.poses[0];
  SolverOptions options;
  SolverSummary summary;
  ASSERT_TRUE(SolveGraphSlam3d(options, &problem, &summary).ok());
  EXPECT_EQ(summary.unknown_poses, 9);
  EXPECT_EQ((problem.poses[0].t - anchor.t).norm(), 0.0);
}

TEST(Initialization3d, EdgesOnlyPosesAreChainedAlongOdometry) {
  Problem3d problem = RandomProblem(8, 0, false, 15);
  problem.relative_poses.resize(7);  // odometry only: the chain is the path
  std::vector<Pose3> chained(8);
  chained[0] = Pose3::Identity();
  for (int i = 1; i < 8; ++i) chained[i] = Compose(chained[i - 1], problem.relative_poses[i - 1].z);
  for (int i = 0; i < 8; ++i) {
    problem.poses[i] = Pose3::Identity();
    problem.pose_initialized[i] = 0;
  }
  ASSERT_TRUE(InitializeProblem3d(&problem).ok());
  for (int i = 0; i < 8; ++i) {
    EXPECT_LT((problem.poses[i].t - chained[i].t).norm(), 1e-12) << i;
    EXPECT_EQ(problem.pose_initialized[i], 1);
  }
}

TEST(Initialization3d, AllIdentityGuessesAreReplacedByTheChain) {
  Problem3d problem = RandomProblem(6, 0, false, 16);
  for (auto& pose : problem.poses) pose = Pose3::Identity();  // "initialized" but empty
  ASSERT_TRUE(InitializeProblem3d(&problem).ok());
  const Pose3 expected = Compose(problem.relative_poses[0].z, problem.relative_poses[1].z);
  EXPECT_LT((problem.poses[2].t - expected.t).norm(), 1e-12);
}

TEST(Initialization3d, FeaturesArePlacedByTheirFirstObservation) {
  Problem3d problem = RandomProblem(6, 2, false, 17);
  problem.feature_initialized[1] = 0;
  ASSERT_TRUE(InitializeProblem3d(&problem).ok());
  const Point3Observation* first = nullptr;
  for (const auto& o : problem.observations)
    if (o.feature == 1) {
      first = &o;
      break;
    }
  ASSERT_NE(first, nullptr);
  EXPECT_LT((problem.features[1] - TransformPoint(problem.poses[first->pose], first->z)).norm(),
            1e-12);
}

TEST(Initialization3d, DisconnectedPoseIsAnErrorNamingTheLine) {
  Problem3d problem = RandomProblem(6, 0, false, 18);
  problem.AddPose(99, Pose3::Identity(), true, 42);
  const Status status = InitializeProblem3d(&problem);
  ASSERT_FALSE(status.ok());
  EXPECT_NE(status.ToString().find("random.g2o:42"), std::string::npos) << status.ToString();
  EXPECT_NE(status.ToString().find("pose 99"), std::string::npos);
}

TEST(Initialization3d, NonPositiveDefiniteInformationIsRejected) {
  Problem3d problem = RandomProblem(6, 0, false, 19);
  problem.relative_poses[2].information(5, 5) = -1.0;
  problem.relative_poses[2].line = 7;
  const Status status = InitializeProblem3d(&problem);
  ASSERT_FALSE(status.ok());
  EXPECT_NE(status.ToString().find("random.g2o:7"), std::string::npos) << status.ToString();
}

// A landmark seen 8 times, 3 of them 1.9 m off (a wrong association): least
// squares drags it towards the outliers, Cauchy holds it near the truth.
TEST(GraphSlamSolver3d, CauchyKernelHoldsOffACorruptedLandmark) {
  std::vector<Point3> truth;
  std::vector<Pose3> true_poses;
  Problem3d input = RandomProblem(16, 4, /*gps=*/false, 21, &truth, &true_poses);
  // As in the 2-D test, the kernel and not the start or a loose trajectory is
  // under test: true initial poses, odometry exact and stiff (else the
  // outliers bend the trajectory instead of moving the landmark).
  input.poses = true_poses;
  for (RelativePose3Constraint& c : input.relative_poses) {
    c.z = Between(true_poses[c.from], true_poses[c.to]);
    c.information *= 100.0;
  }
  std::mt19937 rng(5);
  std::normal_distribution<double> normal(0.0, 0.02);
  for (int k = 0; k < 5; ++k) {  // 5 more observations of landmark 0 (8 in all)
    Point3Observation o;
    o.pose = 1 + 3 * k;
    o.feature = 0;
    o.z = InverseTransformPoint(true_poses[o.pose], truth[0]) +
          Eigen::Vector3d(normal(rng), normal(rng), normal(rng));
    o.information = Eigen::Matrix3d::Identity() * 100.0;
    input.observations.push_back(o);
  }
  int corrupted = 0;
  for (Point3Observation& o : input.observations) {
    if (o.feature != 0 || corrupted >= 3) continue;
    o.z += Eigen::Vector3d(1.5, -1.0, 0.5);
    ++corrupted;
  }
  ASSERT_EQ(corrupted, 3);
  auto landmark_error = [&](const RobustKernel& kernel, SolverSummary* summary) {
    Problem3d problem = input;
    SolverOptions options;
    options.observation_kernel = kernel;
    EXPECT_TRUE(SolveGraphSlam3d(options, &problem, summary).ok());
    EXPECT_TRUE(summary->converged) << summary->termination;
    // chi2 reported with a kernel is the robust cost at the optimum.
    EXPECT_NEAR(summary->final_chi2, Chi2Of3d(problem, problem.poses, problem.features, kernel),
                1e-9 * summary->final_chi2);
    // Landmark error in the frame of pose 0 (the anchor): gauge-free.
    return (problem.features[0] - truth[0]).norm();
  };
  SolverSummary plain_summary, robust_summary;
  const double plain = landmark_error(RobustKernel(), &plain_summary);
  RobustKernel cauchy;
  cauchy.type = RobustKernel::Type::kCauchy;
  cauchy.scale = 2.0;
  const double robust = landmark_error(cauchy, &robust_summary);
  std::printf("landmark error: least squares %.4f m, Cauchy %.4f m\n", plain, robust);
  EXPECT_GT(plain, 0.5) << "the outliers must pull least squares off";
  EXPECT_LT(robust, 0.25 * plain) << "plain " << plain << " robust " << robust;
  EXPECT_LT(robust_summary.final_chi2, plain_summary.final_chi2);
}

// A solve resumed from the checkpoint of iteration 2 ends bit for bit where
// the uninterrupted solve ends: the checkpoint carries the whole state.
TEST(GraphSlamSolver3d, ResumeFromACheckpointIsBitIdentical) {
  const Problem3d input = RandomProblem(14, 6, /*gps=*/false, 22);
  SolverOptions options;
  options.function_tolerance = 1e-14;
  options.parameter_tolerance = 1e-14;
  options.gradient_tolerance = 1e-14;
  options.initial_trust_region_radius = 1e-2;  // several rejected and accepted steps
  RobustKernel huber;
  huber.type = RobustKernel::Type::kHuber;
  huber.scale = 1.0;
  options.observation_kernel = huber;

  Problem3d full = input;
  SolverSummary full_summary;
  std::vector<SolverCheckpoint3d> checkpoints;
  Checkpointing3d record;
  record.callback = [&](const SolverCheckpoint3d& c) {
    checkpoints.push_back(c);
    return Status::Ok();
  };
  ASSERT_TRUE(SolveGraphSlam3d(options, &full, &full_summary, record).ok());
  ASSERT_GE(full_summary.iterations, 4);
  ASSERT_EQ(static_cast<int>(checkpoints.size()), full_summary.iterations);
  EXPECT_TRUE(checkpoints.back().converged);

  Problem3d resumed = input;
  SolverSummary resumed_summary;
  Checkpointing3d resume;
  resume.resume_from = &checkpoints[1];
  ASSERT_TRUE(SolveGraphSlam3d(options, &resumed, &resumed_summary, resume).ok());
  EXPECT_EQ(resumed_summary.resumed_from_iteration, 2);
  EXPECT_EQ(resumed_summary.iterations, full_summary.iterations);
  EXPECT_EQ(resumed_summary.final_chi2, full_summary.final_chi2);
  EXPECT_EQ(resumed_summary.initial_chi2, full_summary.initial_chi2);
  EXPECT_EQ(resumed_summary.termination, full_summary.termination);
  for (int i = 0; i < full.num_poses(); ++i) {
    EXPECT_EQ(resumed.poses[i].t, full.poses[i].t) << i;
    EXPECT_EQ(resumed.poses[i].q.coeffs(), full.poses[i].q.coeffs()) << i;
  }
  for (int f = 0; f < full.num_features(); ++f) EXPECT_EQ(resumed.features[f], full.features[f]);

  // A checkpoint of another problem is refused.
  Problem3d other = RandomProblem(10, 6, false, 23);
  SolverSummary other_summary;
  EXPECT_FALSE(SolveGraphSlam3d(options, &other, &other_summary, resume).ok());
}


// A wrong loop closure (3 m off): least squares bends the trajectory, a
// Cauchy kernel on the relative poses (--robust-kernel odometry=cauchy:2)
// keeps it near the truth.
TEST(GraphSlamSolver3d, CauchyOnRelativePosesHoldsOffAWrongLoopClosure) {
  std::vector<Point3> true_points;
  std::vector<Pose3> truth;
  Problem3d input = RandomProblem(20, 0, /*gps=*/false, 24, &true_points, &truth);
  input.poses = truth;
  for (RelativePose3Constraint& c : input.relative_poses) c.z = Between(truth[c.from], truth[c.to]);
  RelativePose3Constraint wrong = input.relative_poses.back();  // (2, n/2)
  wrong.from = 5;
  wrong.to = 15;
  wrong.z = Between(truth[5], truth[15]);
  wrong.z.t += Eigen::Vector3d(3.0, -2.0, 1.0);
  input.relative_poses.push_back(wrong);
  auto trajectory_error = [&](const PoseFactorKernels& kernels) {
    Problem3d problem = input;
    SolverOptions options;
    options.pose_kernels = kernels;
    SolverSummary summary;
    EXPECT_TRUE(SolveGraphSlam3d(options, &problem, &summary).ok());
    EXPECT_TRUE(summary.converged) << summary.termination;
    EXPECT_NEAR(summary.final_chi2,
                Chi2Of3d(problem, problem.poses, problem.features, RobustKernel(), kernels),
                1e-9 * summary.final_chi2 + 1e-12);
    double worst = 0.0;
    for (int i = 0; i < problem.num_poses(); ++i)
      worst = std::max(worst, (problem.poses[i].t - truth[i].t).norm());
    return worst;
  };
  PoseFactorKernels cauchy;
  cauchy.relative_pose.type = RobustKernel::Type::kCauchy;
  cauchy.relative_pose.scale = 2.0;
  const double plain = trajectory_error(PoseFactorKernels());
  const double robust = trajectory_error(cauchy);
  std::printf("worst pose error: least squares %.4f m, Cauchy %.4f m\n", plain, robust);
  EXPECT_GT(plain, 0.3);
  EXPECT_LT(robust, 0.2 * plain);  // measured 0.146 m vs 1.600 m
}

}  // namespace
}  // namespace graphslam::core

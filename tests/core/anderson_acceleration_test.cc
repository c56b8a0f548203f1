// AndersonAcceleration on linear fixed-point iterations x <- x + f(x),
// f(x) = -A (x - x*), whose plain iteration contracts by the eigenvalues of
// I - A: Anderson mixing is GMRES there, exact once its history spans the
// error's eigenvectors.
#include "core/anderson_acceleration.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>

namespace graphslam::core {
namespace {

struct LinearMap {
  Eigen::MatrixXd a;
  Eigen::VectorXd solution;
  Eigen::VectorXd Step(const Eigen::VectorXd& x) const { return -a * (x - solution); }
};

// I - A with eigenvalues 0.94 (a slowly shrinking mode, as Gauss-Newton's
// along a soft mode), -0.9 (an overshooting one) and 0.5, in a rotated basis.
LinearMap SlowMap() {
  Eigen::Matrix3d q = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  const Eigen::Vector3d contraction(0.94, -0.9, 0.5);
  LinearMap map;
  map.a = Eigen::Matrix3d::Identity() - q * contraction.asDiagonal() * q.transpose();
  map.solution = Eigen::Vector3d(1.0, -2.0, 0.5);
  return map;
}

TEST(AndersonAcceleration, ReachesTheFixedPointWherePlainIterationCrawls) {
  const LinearMap map = SlowMap();
  const Eigen::VectorXd start = Eigen::Vector3d(4.0, 3.0, -1.0);
  const double start_error = (start - map.solution).norm();

  Eigen::VectorXd plain = start;
  for (int k = 0; k < 6; ++k) plain += map.Step(plain);
  EXPECT_GT((plain - map.solution).norm(), 0.3 * start_error);

  AndersonAcceleration anderson(3);
  Eigen::VectorXd x = start;
  int extrapolated = 0;
  for (int k = 0; k < 6; ++k) {
    const Eigen::VectorXd f = map.Step(x);
    Eigen::VectorXd v;
    if (anderson.Extrapolate(f, &v)) ++extrapolated;
    else EXPECT_EQ(v, f);
    x += v;
    anderson.Record(v);
  }
  EXPECT_EQ(extrapolated, 5);  // every step but the first has a history
  EXPECT_EQ(anderson.history_size(), 3);
  EXPECT_LT((x - map.solution).norm(), 1e-9 * start_error);
}

TEST(AndersonAcceleration, ResetForgetsTheHistory) {
  const LinearMap map = SlowMap();
  AndersonAcceleration anderson(2);
  Eigen::VectorXd x = Eigen::Vector3d(4.0, 3.0, -1.0);
  Eigen::VectorXd v;
  for (int k = 0; k < 3; ++k) {
    anderson.Extrapolate(map.Step(x), &v);
    x += v;
    anderson.Record(v);
  }
  EXPECT_EQ(anderson.history_size(), 2);
  anderson.Reset();
  const Eigen::VectorXd f = map.Step(x);
  EXPECT_FALSE(anderson.Extrapolate(f, &v));
  EXPECT_EQ(v, f);
  EXPECT_EQ(anderson.history_size(), 0);
}

// Observe keeps the history as Extrapolate does: skipping the extrapolation
// on some steps still leaves the fixed point to the next ones.
TEST(AndersonAcceleration, ObservedStepsStillBuildTheHistory) {
  const LinearMap map = SlowMap();
  const Eigen::VectorXd start = Eigen::Vector3d(4.0, 3.0, -1.0);
  AndersonAcceleration anderson(3);
  Eigen::VectorXd x = start;
  for (int k = 0; k < 4; ++k) {
    const Eigen::VectorXd f = map.Step(x);
    anderson.Observe(f);
    x += f;
    anderson.Record(f);
  }
  EXPECT_EQ(anderson.history_size(), 3);
  EXPECT_GT((x - map.solution).norm(), 0.3 * (start - map.solution).norm());
  Eigen::VectorXd v;
  ASSERT_TRUE(anderson.Extrapolate(map.Step(x), &v));
  x += v;
  EXPECT_LT((x - map.solution).norm(), 1e-9 * (start - map.solution).norm());
}

// A step extrapolated but not recorded (rejected by the caller, which then
// resets) adds nothing: the next Extrapolate after Reset has no history.
TEST(AndersonAcceleration, AnUnrecordedStepAddsNoPair) {
  const LinearMap map = SlowMap();
  AndersonAcceleration anderson(3);
  Eigen::VectorXd x = Eigen::Vector3d(4.0, 3.0, -1.0);
  Eigen::VectorXd v;
  anderson.Extrapolate(map.Step(x), &v);
  // Not recorded: the same state's step again has still no history.
  EXPECT_FALSE(anderson.Extrapolate(map.Step(x), &v));
  EXPECT_EQ(anderson.history_size(), 0);
}

}  // namespace
}  // namespace graphslam::core

// FitPowerLaw recovers c and k of y = c·x^k exactly, and by least squares
// on the logarithms from noisy points.
#include "tools/benchmark/power_law_fit.h"

#include <gtest/gtest.h>

#include <cmath>

namespace graphslam::tools::benchmark {
namespace {

TEST(PowerLawFit, ExactPowerLawIsRecovered) {
  std::vector<double> x = {1e4, 1e5, 1e6, 1e7, 1e8}, y;
  for (double v : x) y.push_back(3.0 * std::pow(v, 1.5));
  const PowerLaw fit = FitPowerLaw(x, y);
  ASSERT_TRUE(fit.valid);
  EXPECT_NEAR(fit.exponent, 1.5, 1e-12);
  EXPECT_NEAR(fit.coefficient, 3.0, 1e-9);
  EXPECT_EQ(fit.points, 5);
}

// The slope of the least-squares line through (log x, log y): for two
// points it is the secant; a third point off the line pulls it as the
// normal equations say (computed here by hand).
TEST(PowerLawFit, LeastSquaresOnTheLogarithms) {
  const std::vector<double> x = {1.0, std::exp(1.0), std::exp(2.0)};
  const std::vector<double> y = {1.0, std::exp(1.0), std::exp(3.0)};  // logs 0, 1, 3
  const PowerLaw fit = FitPowerLaw(x, y);
  ASSERT_TRUE(fit.valid);
  // lx = 0,1,2 (mean 1), ly = 0,1,3 (mean 4/3): cov 1, var 2/3, slope 1.5.
  EXPECT_NEAR(fit.exponent, 1.5, 1e-12);
  EXPECT_NEAR(std::log(fit.coefficient), 4.0 / 3.0 - 1.5 * 1.0, 1e-12);
}

TEST(PowerLawFit, NonPositiveAndSingleSizeAreNotFitted) {
  EXPECT_FALSE(FitPowerLaw({1e4}, {2.0}).valid);
  EXPECT_FALSE(FitPowerLaw({1e4, 1e4}, {2.0, 3.0}).valid);
  const PowerLaw fit = FitPowerLaw({0.0, 1e4, 1e5, 1e6}, {5.0, 1.0, -1.0, 100.0});
  ASSERT_TRUE(fit.valid);
  EXPECT_EQ(fit.points, 2);  // (1e4, 1) and (1e6, 100)
  EXPECT_NEAR(fit.exponent, 1.0, 1e-12);
}

}  // namespace
}  // namespace graphslam::tools::benchmark

// ChiSquareQuantile (partition/association/internal/chi_square.h): the
// quantile F^{-1}(Phi(z); k) of every association gate, against references
// that do not go through Boost: the closed form for 2 dof with Phi from
// std::erfc, and published table values. The tolerance tells the exact
// quantile from Wilson and Hilferty's approximation.
#include "partition/association/internal/chi_square.h"

#include <cmath>
#include <limits>

#include <gtest/gtest.h>

namespace graphslam::partition::internal {
namespace {

constexpr double kRelativeTolerance = 1e-4;

// 1 - Phi(z), without Boost.
double NormalTail(double z) { return 0.5 * std::erfc(z / std::sqrt(2.0)); }

// Wilson-Hilferty's cube-root normal approximation of the same quantile.
double WilsonHilferty(double dof, double z) {
  const double a = 2.0 / (9.0 * dof);
  const double c = 1.0 - a + z * std::sqrt(a);
  return dof * c * c * c;
}

bool WithinTolerance(double value, double reference) {
  return std::abs(value / reference - 1.0) <= kRelativeTolerance;
}

TEST(ChiSquareQuantile, TwoDofIsTheClosedForm) {
  // F(x; 2) = 1 - exp(-x / 2), so F^{-1}(p; 2) = -2 ln(1 - p).
  for (double z : {-1.5, 0.0, 1.0, 1.6449, 2.3263, 3.09, 4.0, 6.0, 8.0}) {
    const double reference = -2.0 * std::log(NormalTail(z));
    EXPECT_TRUE(WithinTolerance(ChiSquareQuantile(2.0, z), reference))
        << "z " << z << ": " << ChiSquareQuantile(2.0, z) << " vs " << reference;
  }
}

// Upper-tail points of the chi-square distribution as published (NIST/SEMATECH
// e-Handbook of Statistical Methods, table 1.3.6.7.4; Abramowitz and Stegun
// table 26.8), at the normal z of the same probability.
struct TablePoint {
  double p;
  double z;  // Phi^{-1}(p)
  double dof;
  double quantile;
};
constexpr TablePoint kTable[] = {
    {0.95, 1.6448536269514722, 1.0, 3.8415},   {0.95, 1.6448536269514722, 3.0, 7.8147},
    {0.95, 1.6448536269514722, 20.0, 31.4104}, {0.99, 2.3263478740408408, 2.0, 9.2103},
    {0.99, 2.3263478740408408, 6.0, 16.8119},  {0.999, 3.0902323061678132, 2.0, 13.8155},
    {0.999, 3.0902323061678132, 4.0, 18.4668}, {0.999, 3.0902323061678132, 10.0, 29.5883},
    {0.999, 3.0902323061678132, 20.0, 45.3147},
};

TEST(ChiSquareQuantile, MatchesPublishedTables) {
  for (const TablePoint& t : kTable) {
    ASSERT_NEAR(1.0 - NormalTail(t.z), t.p, 1e-12);  // the z column is right
    EXPECT_TRUE(WithinTolerance(ChiSquareQuantile(t.dof, t.z), t.quantile))
        << "p " << t.p << " dof " << t.dof << ": " << ChiSquareQuantile(t.dof, t.z) << " vs "
        << t.quantile;
  }
}

TEST(ChiSquareQuantile, TheToleranceRejectsWilsonHilferty) {
  // Wilson-Hilferty is 0.1-2.3 % off at these points (2-10 dof), so a
  // quantile computed that way fails the two tests above.
  for (const TablePoint& t : kTable) {
    if (t.dof < 2.0 || t.dof > 10.0) continue;
    EXPECT_FALSE(WithinTolerance(WilsonHilferty(t.dof, t.z), t.quantile))
        << "p " << t.p << " dof " << t.dof << ": " << WilsonHilferty(t.dof, t.z);
  }
  for (double z : {1.0, 3.09, 6.0}) {
    EXPECT_FALSE(WithinTolerance(WilsonHilferty(2.0, z), -2.0 * std::log(NormalTail(z))))
        << "z " << z;
  }
}

TEST(ChiSquareQuantile, GrowsWithZAndDof) {
  double previous = 0.0;
  for (double z = -3.0; z <= 8.0; z += 0.5) {
    const double q = ChiSquareQuantile(4.0, z);
    EXPECT_GT(q, previous) << "z " << z;
    previous = q;
  }
  for (double dof = 2.0; dof <= 40.0; dof += 2.0)
    EXPECT_GT(ChiSquareQuantile(dof + 2.0, 3.09), ChiSquareQuantile(dof, 3.09)) << dof;
}

TEST(ChiSquareQuantile, ExtremeZGivesValuesNotExceptions) {
  EXPECT_EQ(ChiSquareQuantile(2.0, 40.0), std::numeric_limits<double>::infinity());
  EXPECT_EQ(ChiSquareQuantile(2.0, -40.0), 0.0);
  EXPECT_TRUE(std::isnan(ChiSquareQuantile(2.0, std::numeric_limits<double>::quiet_NaN())));
}

}  // namespace
}  // namespace graphslam::partition::internal

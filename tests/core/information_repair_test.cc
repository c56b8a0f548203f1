// core/information_repair.h: a non-PD matrix becomes PD with the floor, a PD
// one is unchanged, and the result is the nearest such matrix.
#include "core/information_repair.h"

#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

namespace graphslam::core {
namespace {

TEST(InformationRepair, PositiveDefiniteMatricesAreLeftBitForBit) {
  Eigen::Matrix3d information;
  information << 100, 1, 0, 1, 50, 0, 0, 0, 1e-9;  // PD, one eigenvalue far below the floor
  const Eigen::Matrix3d before = information;
  EXPECT_FALSE(RepairInformation(&information));
  EXPECT_EQ(information, before);
  Eigen::Matrix<double, 6, 6> identity = Eigen::Matrix<double, 6, 6>::Identity();
  EXPECT_FALSE(RepairInformation(&identity));
  EXPECT_EQ(identity, (Eigen::Matrix<double, 6, 6>::Identity()));
}

TEST(InformationRepair, IndefiniteBecomesPositiveDefiniteWithTheFloor) {
  // Eigenvalues 4 and -1 along (1, 1)/sqrt2 and (1, -1)/sqrt2.
  Eigen::Matrix2d information;
  information << 1.5, 2.5, 2.5, 1.5;
  ASSERT_TRUE(RepairInformation(&information));
  EXPECT_EQ(Eigen::LLT<Eigen::Matrix2d>(information).info(), Eigen::Success);
  EXPECT_EQ(information, information.transpose());
  const Eigen::Vector2d values = Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(information)
                                     .eigenvalues();
  EXPECT_NEAR(values(0), 4e-6, 1e-15);  // the floor: 1e-6 * max |l| = 1e-6 * 4
  EXPECT_NEAR(values(1), 4.0, 1e-12);
  // The kept eigenvector is unchanged: A' (1, 1) = 4 (1, 1).
  EXPECT_NEAR((information * Eigen::Vector2d(1, 1) - 4.0 * Eigen::Vector2d(1, 1)).norm(), 0.0,
              1e-12);
  // Nearest: the Frobenius distance is |(-1) - 4e-6|, that of the clipped eigenvalue.
  Eigen::Matrix2d original;
  original << 1.5, 2.5, 2.5, 1.5;
  EXPECT_NEAR((information - original).norm(), 1.0 + 4e-6, 1e-12);
}

TEST(InformationRepair, SemidefiniteAndZeroMatrices) {
  // A 6x6 pose information with a zero rotational block (only translation known).
  Eigen::Matrix<double, 6, 6> information = Eigen::Matrix<double, 6, 6>::Zero();
  information.topLeftCorner<3, 3>() = 200.0 * Eigen::Matrix3d::Identity();
  ASSERT_TRUE(RepairInformation(&information));
  using Matrix6d = Eigen::Matrix<double, 6, 6>;
  EXPECT_EQ(Eigen::LLT<Matrix6d>(information).info(), Eigen::Success);
  EXPECT_NEAR(information(3, 3), 2e-4, 1e-15);
  EXPECT_NEAR(information(0, 0), 200.0, 1e-12);
  Eigen::Matrix3d zero = Eigen::Matrix3d::Zero();
  ASSERT_TRUE(RepairInformation(&zero));
  EXPECT_NEAR((zero - 1e-6 * Eigen::Matrix3d::Identity()).norm(), 0.0, 1e-18);
}

TEST(InformationRepair, CountsAndKeepsTheFirstLines) {
  InformationRepairs repairs;
  for (int32_t line = 1; line <= 25; ++line) repairs.Record(line);
  EXPECT_EQ(repairs.count, 25);
  ASSERT_EQ(repairs.first_lines.size(), InformationRepairs::kMaxLines);
  EXPECT_EQ(repairs.first_lines.front(), 1);
  EXPECT_EQ(repairs.first_lines.back(), 10);
}

}  // namespace
}  // namespace graphslam::core

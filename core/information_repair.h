// Repair of information matrices that are not positive definite (opt-in:
// `graphslam solve --repair-information`, job key solver.repair_information).
//
// Some published pose graphs carry information matrices with a zero or
// negative eigenvalue (rounded covariances, hand-edited files). The readers
// reject them naming the line; with repair on, each such matrix A is replaced
// by the nearest symmetric matrix (Frobenius norm) whose eigenvalues are at
// least a floor eps (Higham, "Computing a nearest symmetric positive
// semidefinite matrix", 1988, plus the floor):
//
//   S = (A + A^T) / 2 = V diag(l_1..l_n) V^T            (eigen-decomposition)
//   A' = V diag(max(l_i, eps)) V^T,   eps = 1e-6 * max_i |l_i|
//
// (eps = 1e-6 when every l_i is 0). The floor keeps A' invertible with a
// condition number of at most 1e6 in the repaired directions, so a direction
// the file gave no (or negative) information about gets a tiny weight instead
// of none. A matrix that is already positive definite (Cholesky succeeds) is
// left exactly as it is, even if an eigenvalue is below eps.
//
// THREAD SAFETY: pure functions; InformationRepairs is a plain counter.
// ALLOCATION: none (fixed-size matrices).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

namespace graphslam::core {

inline constexpr double kInformationEigenvalueFloor = 1e-6;  // relative, see above

// Returns true (and replaces *information) if it was not positive definite.
// The 1x1 case (a scalar weight w <= 0) becomes the floor 1e-6 * |w|.
bool RepairInformation(double* information);
bool RepairInformation(Eigen::Matrix2d* information);
bool RepairInformation(Eigen::Matrix3d* information);
bool RepairInformation(Eigen::Matrix<double, 6, 6>* information);

// What a reader repaired: how many matrices, and the first lines.
struct InformationRepairs {
  static constexpr size_t kMaxLines = 10;
  int64_t count = 0;
  std::vector<int32_t> first_lines;  // at most kMaxLines
  void Record(int32_t line) {
    ++count;
    if (first_lines.size() < kMaxLines) first_lines.push_back(line);
  }
};

// The readers' opt-in, for a matrix they found not positive definite at
// `line`: false when repair is off (`repairs` null; the reader rejects the
// file naming the line), else repairs *information, counts it and returns true.
template <typename Information>
bool RepairAndCount(InformationRepairs* repairs, int32_t line, Information* information) {
  if (repairs == nullptr) return false;
  RepairInformation(information);
  repairs->Record(line);
  return true;
}

}  // namespace graphslam::core

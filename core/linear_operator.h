// LinearOperator: the only view of a matrix that the iterative solvers need.
//
//   y <- y + A x        (RightMultiplyAndAccumulate)
//
// A is square (num_rows() x num_rows()). Matrices (BlockSparseMatrix),
// preconditioners (BlockJacobiPreconditioner, which applies M^{-1}) and test
// doubles implement it, so the conjugate-gradient loop never sees a storage
// format. After Ceres' LinearOperator / ConjugateGradientsLinearOperator.
//
// THREAD SAFETY: implementations document their own; RightMultiplyAndAccumulate
// is const and the ones in core/ may be called concurrently on distinct outputs.
//
// ALLOCATION: RightMultiplyAndAccumulate must not allocate (it runs inside the
// PCG loop).
#pragma once

namespace graphslam::core {

class LinearOperator {
 public:
  virtual ~LinearOperator() = default;

  // Number of rows (= columns) of A.
  virtual int num_rows() const = 0;

  // y += A x. `x` and `y` hold num_rows() doubles each and must not alias.
  virtual void RightMultiplyAndAccumulate(const double* x, double* y) const = 0;

 protected:
  LinearOperator() = default;
  LinearOperator(const LinearOperator&) = default;
  LinearOperator& operator=(const LinearOperator&) = default;
  LinearOperator(LinearOperator&&) = default;
  LinearOperator& operator=(LinearOperator&&) = default;
};

}  // namespace graphslam::core

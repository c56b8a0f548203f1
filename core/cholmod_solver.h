// CholmodSolver: sparse Cholesky factorization of the reduced information
// matrix S (symmetric positive definite) and solves S x = b with it:
//
//   P S P^T = L L^T   (CHOLMOD supernodal, fill-reducing ordering P by AMD)
//   x = P^T L^{-T} L^{-1} P b
//
// Y. Chen, T. A. Davis, W. W. Hager, S. Rajamanickam, "Algorithm 887:
// CHOLMOD, supernodal sparse Cholesky factorization and update/downdate",
// ACM TOMS 35(3), 2008. Used through Eigen's CholmodSupernodalLLT on the
// upper triangle (BlockSparseMatrix::ToSparseUpper).
//
// The symbolic analysis (ordering, elimination tree, supernodes) depends only
// on the sparsity pattern; Factorize repeats it only on the first call or
// when the pattern differs from the previous one (compared exactly), so the
// Gauss-Newton / Levenberg-Marquardt iterations pay only the numeric
// factorization. CHOLMOD's own printing is switched off (libraries never
// print); failures come back as Status.
//
// THREAD SAFETY: not thread-safe, not even Solve (CHOLMOD's workspace in the
// common object is mutated). Use one CholmodSolver per thread.
//
// ALLOCATION: Factorize builds a compressed copy of the upper triangle
// (O(nnz)) and CHOLMOD allocates the factor (O(nnz(L))); Solve allocates
// CHOLMOD's dense result of size n.
#pragma once

#include <Eigen/Core>
#include <memory>

#include "core/block_sparse_matrix.h"
#include "core/status.h"

namespace graphslam::core {

class CholmodSolver {
 public:
  CholmodSolver();
  ~CholmodSolver();
  CholmodSolver(const CholmodSolver&) = delete;
  CholmodSolver& operator=(const CholmodSolver&) = delete;

  // Factorizes a. Status::Numerical "reduced information matrix is not positive
  // definite (CHOLMOD) ..." naming the failing column and block row if S is
  // not positive definite; Status::Numerical with CHOLMOD's status code for
  // other CHOLMOD failures (e.g. out of memory). After a failure Solve must
  // not be called until a Factorize succeeds.
  [[nodiscard]] Status Factorize(const BlockSparseMatrix& a);

  // x = S^{-1} b with the last successful factorization. b has num_rows()
  // entries (InvalidArgument otherwise). Numerical if CHOLMOD fails or the
  // result is not finite.
  [[nodiscard]] Status Solve(const Eigen::VectorXd& b, Eigen::VectorXd* x) const;

  // How many times the symbolic analysis ran (for tests and logs).
  int num_analyses() const;
  bool factorized() const;
  int num_rows() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace graphslam::core

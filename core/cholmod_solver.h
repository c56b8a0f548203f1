// CholmodSolver: sparse Cholesky factorization of the reduced information
// matrix S (symmetric positive definite) and solves S x = b with it:
//
//   B = P S P^T = L L^T   (fill-reducing ordering P: CHOLMOD's AMD, or METIS
//                          when AMD fills badly, combined with the weighted
//                          postorder of the elimination tree)
//   x = P^T L^{-T} L^{-1} P b
//
// Y. Chen, T. A. Davis, W. W. Hager, S. Rajamanickam, "Algorithm 887:
// CHOLMOD, supernodal sparse Cholesky factorization and update/downdate",
// ACM TOMS 35(3), 2008. Called through CHOLMOD's C interface.
//
// Everything that depends only on the sparsity pattern is done once per
// pattern (compared exactly, block by block, on every Factorize):
//  1. the ordering (AnalyzeCholmodOrdering; ChooseLinearSolver runs it to
//     pick the solver and hands it over with UseOrdering, so it is not
//     repeated);
//  2. B's pattern, already permuted, in the triangle CHOLMOD factorizes
//     without transposing (lower for the supernodal factorization, upper for
//     the simplicial one), with the position in S's stored blocks of every
//     entry (a gather map);
//  3. CHOLMOD's symbolic analysis of B in its natural order (elimination
//     tree, column counts, supernodes).
// A Factorize with the same pattern then gathers S's values into B (one pass,
// no allocation) and runs only the numeric factorization; CHOLMOD's own
// cholmod_factorize would otherwise permute and transpose the matrix every
// time (two copies of it).
//
// The ordering is AMD's on the graph of the pose blocks, expanded to their
// scalar rows (a third or a sixth of the nodes of the scalar graph, and the
// same fill, since every stored block is dense); where CHOLMOD's default
// strategy would also try METIS (large dense factors) it runs on the scalar
// pattern instead.
//
// Supernodal or simplicial: as CHOLMOD's automatic choice, but at 20 flops
// per factor nonzero instead of its 40 (the supernodal factorization's
// OpenMP regions run inline, core/serial_openmp.h, which makes its
// per-supernode cost lower than CHOLMOD's switch assumes): the supernodal
// factorization for dense supernodes (BLAS), the simplicial LL^T for very
// sparse factors (pose chains with few loops).
//
// CHOLMOD's own printing is switched off (libraries never print); failures
// come back as Status.
//
// THREAD SAFETY: not thread-safe, not even Solve (CHOLMOD's workspace in the
// common object is mutated). Use one CholmodSolver per thread.
//
// ALLOCATION: per pattern, O(nnz) for B and its map and CHOLMOD's factor
// (O(nnz(L))); per Factorize nothing beyond CHOLMOD's numeric work; Solve
// keeps its dense workspaces across calls.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <vector>

#include "core/block_sparse_matrix.h"
#include "core/status.h"

namespace graphslam::core {

// The fill-reducing ordering of a block pattern and what its factor costs.
struct CholmodOrdering {
  // Scalar permutation: row k of P S P^T is row permutation[k] of S.
  std::vector<int> permutation;
  double factor_nonzeros = 0;  // CHOLMOD's lnz
  double factor_flops = 0;     // CHOLMOD's fl
  // The pattern it orders (BlockSparseMatrix::row_start / block_cols).
  int block_size = 0;
  std::vector<int64_t> row_start;
  std::vector<int> block_cols;

  bool Orders(const BlockSparseMatrix& a) const;
};

// CHOLMOD's ordering and symbolic analysis of a's pattern (values are not
// read). Numerical with CHOLMOD's status if it fails. Requires
// a.num_rows() > 0.
StatusOr<std::shared_ptr<const CholmodOrdering>> AnalyzeCholmodOrdering(
    const BlockSparseMatrix& a);

class CholmodSolver {
 public:
  CholmodSolver();
  ~CholmodSolver();
  CholmodSolver(const CholmodSolver&) = delete;
  CholmodSolver& operator=(const CholmodSolver&) = delete;

  // An ordering computed already for the pattern of the matrices to come;
  // used by the next analysis whose pattern it orders, ignored otherwise.
  void UseOrdering(std::shared_ptr<const CholmodOrdering> ordering);

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
  // Whether the current pattern's factorization is supernodal.
  bool supernodal() const;
  bool factorized() const;
  int num_rows() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace graphslam::core

// PetscReducedSolver: the linear solve of the reduced pose system
//
//   (S + lambda diag(D)) dx = rhs,    S = sum over ranks r of S_r,  rhs = sum of rhs_r
//
// when every MPI rank holds only the Schur contributions S_r, rhs_r of its own
// chunks (core/chunk_passes.h ReducePass into a local BlockSparseMatrix whose
// pattern is its chunks' pose pairs). The matrix is distributed by block rows
// (distributed/chunk_assignment.h SplitRows) as a PETSc block matrix
// (MATBAIJ by default, block size b = 3 in the plane; `-mat_type aij|sbaij`
// works too) and solved by a PETSc KSP: CG by default with the
// unpreconditioned residual test |S dx - rhs| <= rtol |rhs|, rtol the
// exact-solve tolerance of the one-process solver (--pcg-eta-min); every
// PETSc option (-ksp_type, -ksp_rtol, -pc_type bjacobi|asm|gamg|hypre, ...)
// overrides these defaults.
//
// Assembly. Rank r sends each stored upper block U_ik of S_r to the owner of
// row i and, if another rank, to the owner of row k (which stores U_ik^T in
// its row k), and rhs_r's segment of every rank's rows to that rank. The
// owner sums the received copies of each block in ascending rank order, adds
// lambda D to its diagonal blocks, and inserts its rows (INSERT_VALUES, all
// entries local and preallocated). The sends are one MPI_Alltoallv per solve
// whose layout is fixed at construction (the patterns do not change), so the
// summation order, and with it the matrix, is the same in every run: PETSc's
// own ADD_VALUES stash would add remote contributions in arrival order.
// The solution's owned segments are gathered to every rank (MPI_Allgatherv):
// each rank recovers its features with the whole pose step.
//
// Not done here (docs/distributed.md): the forcing sequence, truncation,
// warm start and deflation of core/reduced_system_solver.h; a checkpointable
// solver state (SaveState reports none).
//
// THREAD SAFETY: one object per solve; collective: every rank calls every
// method in the same order. ALLOCATION: the exchange buffers (the blocks each
// rank sends and receives), the PETSc objects, O(n) vectors.
#pragma once

#include <mpi.h>
#include <petscksp.h>

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/block_sparse_matrix.h"
#include "core/chunk_passes.h"
#include "core/pcg_solver_state.h"
#include "core/reduced_system_solver.h"
#include "core/status.h"

namespace graphslam::distributed {

// What this rank's solves cost, for the report and docs/distributed.md.
struct ExchangeStats {
  int64_t bytes_sent_per_solve = 0;  // by this rank, its own copy excluded
  int64_t owned_blocks = 0;          // distinct upper blocks this rank assembles
  int64_t row_blocks = 0;            // nonzero blocks of this rank's rows (both triangles)
  int64_t solves = 0;
  double exchange_seconds = 0;       // packing, MPI_Alltoallv, sums, PETSc assembly
  double ksp_seconds = 0;            // KSPSolve (setup of the preconditioner included)
  double ksp_cpu_seconds = 0;        // the same in this process's CPU time
  double gather_seconds = 0;         // MPI_Allgatherv of the step
  int64_t gather_bytes_sent = 0;     // by this rank, all solves
  int64_t ksp_iterations = 0;        // all solves
  // Off-rank vector entries a product with S needs in this rank's rows: the
  // bytes one CG iteration's halo exchange brings in (x 8), PETSc's VecScatter.
  int64_t halo_values = 0;
  // The Ranks policy's MPI_Allreduce calls (distributed/mpi_ranks.h): their
  // count, payload bytes sent by this rank and seconds, waits for slower
  // ranks included.
  int64_t reductions = 0;
  int64_t reduction_bytes = 0;
  double reduction_seconds = 0;
  std::string ksp_type, pc_type;     // after the options, e.g. "cg", "bjacobi"
};

class PetscReducedSolver {
 public:
  // Collective. `pattern` is this rank's local reduced matrix (its pattern
  // only is read); `first` the block row split (SplitRows); *stats (not
  // null, must outlive the solver) is kept up to date. Errors: a PETSc or MPI
  // failure, as Numerical naming the call.
  static StatusOr<std::unique_ptr<PetscReducedSolver>> Create(
      MPI_Comm comm, const core::BlockSparseMatrix& pattern, const std::vector<int>& first,
      const core::ReducedSystemSolverOptions& options, ExchangeStats* stats);
  ~PetscReducedSolver();
  PetscReducedSolver(const PetscReducedSolver&) = delete;
  PetscReducedSolver& operator=(const PetscReducedSolver&) = delete;

  // Collective. Solves (sum_r S_r + lambda diag(damping)) x = sum_r rhs_r;
  // `damping` and lambda are the same on every rank, *x (all rows) is the
  // same on every rank. A KSP that does not converge is Numerical (the LM
  // driver then raises the damping, on every rank alike).
  Status Solve(double lambda, const Eigen::VectorXd& damping, core::ReducedSystem* system,
               Eigen::VectorXd* x, int* iterations, double chi2);
  void StepResult(bool /*accepted*/) {}
  void SaveState(core::PcgSolverState* state) const { state->present = false; }
  Status RestoreState(const core::PcgSolverState& /*state*/,
                      const core::BlockSparseMatrix& /*pattern*/) {
    return Status::Ok();
  }

 private:
  PetscReducedSolver() = default;
  Status Setup(const core::BlockSparseMatrix& pattern,
               const core::ReducedSystemSolverOptions& options);

  MPI_Comm comm_ = MPI_COMM_NULL;
  int rank_ = 0;
  int size_ = 1;
  int b_ = 3;
  std::vector<int> first_;
  // Sends: per destination, the local stored blocks (indices into the local
  // matrix) in the order the receiver expects; counts/displacements in doubles.
  std::vector<std::vector<int64_t>> send_blocks_;
  std::vector<int> send_counts_, send_displs_, recv_counts_, recv_displs_;
  // Receives: for each received block, in the receive buffer's order, its slot.
  std::vector<int64_t> recv_slot_;
  // The distinct upper blocks (i, k) this rank assembles, and their sums.
  std::vector<int> slot_row_, slot_col_;
  std::vector<double> slot_values_;
  std::vector<int64_t> diagonal_slot_;  // per owned row
  std::vector<double> send_buffer_, recv_buffer_;
  std::vector<int> gather_counts_, gather_displs_;
  Mat matrix_ = nullptr;
  Vec rhs_ = nullptr;
  Vec solution_ = nullptr;
  KSP ksp_ = nullptr;
  ExchangeStats* stats_ = nullptr;
};

}  // namespace graphslam::distributed

#include "distributed/petsc_reduced_solver.h"

#include <algorithm>
#include <chrono>
#include <ctime>
#include <string>
#include <utility>

#include "core/logging.h"
#include "distributed/chunk_assignment.h"

namespace graphslam::distributed {
namespace {

// CPU seconds of this process (all threads) so far: the KSP's cost on a
// loaded machine, where its wall time also counts the waits for a core.
double ProcessCpuSeconds() {
  timespec now{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &now);
  return static_cast<double>(now.tv_sec) + 1e-9 * static_cast<double>(now.tv_nsec);
}

// A PETSc or MPI error code as a Status naming the call.
#define GS_PETSC(call)                                                                   \
  do {                                                                                   \
    const PetscErrorCode gs_petsc_error_ = (call);                                       \
    if (gs_petsc_error_ != 0)                                                            \
      return Status::Numerical(std::string("PETSc: ") + #call + " failed with error " + \
                               std::to_string(static_cast<int>(gs_petsc_error_)));       \
  } while (0)
#define GS_MPI(call)                                                                   \
  do {                                                                                 \
    const int gs_mpi_error_ = (call);                                                  \
    if (gs_mpi_error_ != MPI_SUCCESS)                                                  \
      return Status::Numerical(std::string("MPI: ") + #call + " failed with error " + \
                               std::to_string(gs_mpi_error_));                         \
  } while (0)

std::vector<int> Displacements(const std::vector<int>& counts) {
  std::vector<int> displs(counts.size(), 0);
  for (size_t r = 1; r < counts.size(); ++r) displs[r] = displs[r - 1] + counts[r - 1];
  return displs;
}

}  // namespace

StatusOr<std::unique_ptr<PetscReducedSolver>> PetscReducedSolver::Create(
    MPI_Comm comm, const core::BlockSparseMatrix& pattern, const std::vector<int>& first,
    const core::ReducedSystemSolverOptions& options, ExchangeStats* stats) {
  std::unique_ptr<PetscReducedSolver> solver(new PetscReducedSolver());
  solver->stats_ = stats;
  *stats = ExchangeStats();
  solver->comm_ = comm;
  MPI_Comm_rank(comm, &solver->rank_);
  MPI_Comm_size(comm, &solver->size_);
  solver->first_ = first;
  solver->b_ = pattern.block_size();
  GS_RETURN_IF_ERROR(solver->Setup(pattern, options));
  return solver;
}

PetscReducedSolver::~PetscReducedSolver() {
  if (ksp_ != nullptr) KSPDestroy(&ksp_);
  if (matrix_ != nullptr) MatDestroy(&matrix_);
  if (rhs_ != nullptr) VecDestroy(&rhs_);
  if (solution_ != nullptr) VecDestroy(&solution_);
}

Status PetscReducedSolver::Setup(const core::BlockSparseMatrix& pattern,
                                 const core::ReducedSystemSolverOptions& options) {
  const int b = b_;
  const int bb = b * b;
  const int rows_begin = first_[rank_];
  const int rows_end = first_[rank_ + 1];
  const int owned_rows = rows_end - rows_begin;

  // 1. Which of my stored blocks go where: U_ik to owner(i) and owner(k).
  send_blocks_.assign(size_, {});
  std::vector<std::vector<int>> send_pairs(size_);
  const std::vector<int64_t>& row_start = pattern.row_start();
  const std::vector<int>& block_cols = pattern.block_cols();
  for (int i = 0; i < pattern.num_block_rows(); ++i) {
    const int owner_i = RowOwner(first_, i);
    for (int64_t j = row_start[i]; j < row_start[i + 1]; ++j) {
      const int k = block_cols[j];
      const int owner_k = RowOwner(first_, k);
      send_blocks_[owner_i].push_back(j);
      send_pairs[owner_i].insert(send_pairs[owner_i].end(), {i, k});
      if (owner_k != owner_i) {
        send_blocks_[owner_k].push_back(j);
        send_pairs[owner_k].insert(send_pairs[owner_k].end(), {i, k});
      }
    }
  }

  // 2. Exchange the pairs once: every rank learns which blocks it receives.
  std::vector<int> pair_send_counts(size_), pair_recv_counts(size_);
  for (int d = 0; d < size_; ++d) pair_send_counts[d] = static_cast<int>(send_pairs[d].size());
  GS_MPI(MPI_Alltoall(pair_send_counts.data(), 1, MPI_INT, pair_recv_counts.data(), 1, MPI_INT,
                      comm_));
  std::vector<int> pair_send_flat;
  for (int d = 0; d < size_; ++d)
    pair_send_flat.insert(pair_send_flat.end(), send_pairs[d].begin(), send_pairs[d].end());
  send_pairs = {};
  const std::vector<int> pair_send_displs = Displacements(pair_send_counts);
  const std::vector<int> pair_recv_displs = Displacements(pair_recv_counts);
  std::vector<int> pair_recv_flat(static_cast<size_t>(pair_recv_displs.back() +
                                                      pair_recv_counts.back()));
  GS_MPI(MPI_Alltoallv(pair_send_flat.data(), pair_send_counts.data(), pair_send_displs.data(),
                       MPI_INT, pair_recv_flat.data(), pair_recv_counts.data(),
                       pair_recv_displs.data(), MPI_INT, comm_));

  // 3. The distinct blocks I assemble (sorted), and each received block's slot.
  const size_t received = pair_recv_flat.size() / 2;
  std::vector<std::pair<int, int>> pairs(received);
  for (size_t t = 0; t < received; ++t) pairs[t] = {pair_recv_flat[2 * t], pair_recv_flat[2 * t + 1]};
  std::vector<std::pair<int, int>> distinct = pairs;
  std::sort(distinct.begin(), distinct.end());
  distinct.erase(std::unique(distinct.begin(), distinct.end()), distinct.end());
  recv_slot_.resize(received);
  for (size_t t = 0; t < received; ++t)
    recv_slot_[t] = std::lower_bound(distinct.begin(), distinct.end(), pairs[t]) - distinct.begin();
  slot_row_.resize(distinct.size());
  slot_col_.resize(distinct.size());
  for (size_t s = 0; s < distinct.size(); ++s) {
    slot_row_[s] = distinct[s].first;
    slot_col_[s] = distinct[s].second;
  }
  slot_values_.assign(distinct.size() * bb, 0.0);
  stats_->owned_blocks = static_cast<int64_t>(distinct.size());
  diagonal_slot_.assign(owned_rows, -1);
  for (size_t s = 0; s < distinct.size(); ++s) {
    if (slot_row_[s] == slot_col_[s]) diagonal_slot_[slot_row_[s] - rows_begin] = s;
  }
  for (int r = 0; r < owned_rows; ++r) {
    if (diagonal_slot_[r] < 0)
      return Status::Numerical("distributed reduced system: no diagonal block for row " +
                               std::to_string(rows_begin + r));
  }

  // 4. Value exchange layout: blocks then my rhs segment for each destination.
  send_counts_.assign(size_, 0);
  recv_counts_.assign(size_, 0);
  for (int d = 0; d < size_; ++d) {
    send_counts_[d] = static_cast<int>(send_blocks_[d].size()) * bb + (first_[d + 1] - first_[d]) * b;
    recv_counts_[d] = pair_recv_counts[d] / 2 * bb + owned_rows * b;
  }
  send_displs_ = Displacements(send_counts_);
  recv_displs_ = Displacements(recv_counts_);
  send_buffer_.resize(static_cast<size_t>(send_displs_.back() + send_counts_.back()));
  recv_buffer_.resize(static_cast<size_t>(recv_displs_.back() + recv_counts_.back()));
  for (int d = 0; d < size_; ++d)
    if (d != rank_) stats_->bytes_sent_per_solve += int64_t{8} * send_counts_[d];
  gather_counts_.resize(size_);
  for (int d = 0; d < size_; ++d) gather_counts_[d] = (first_[d + 1] - first_[d]) * b;
  gather_displs_ = Displacements(gather_counts_);

  // 5. The PETSc matrix, preallocated per block row (diagonal / off-diagonal
  // part; upper triangle only for SBAIJ).
  std::vector<std::vector<int>> row_cols(owned_rows);
  for (size_t s = 0; s < distinct.size(); ++s) {
    const int i = slot_row_[s];
    const int k = slot_col_[s];
    if (i >= rows_begin && i < rows_end) row_cols[i - rows_begin].push_back(k);
    if (k != i && k >= rows_begin && k < rows_end) row_cols[k - rows_begin].push_back(i);
  }
  std::vector<PetscInt> d_nnz(owned_rows, 0), o_nnz(owned_rows, 0), du_nnz(owned_rows, 0),
      ou_nnz(owned_rows, 0);
  std::vector<int> halo;  // off-rank block columns of my rows
  for (int r = 0; r < owned_rows; ++r) {
    std::vector<int>& cols = row_cols[r];
    std::sort(cols.begin(), cols.end());
    cols.erase(std::unique(cols.begin(), cols.end()), cols.end());
    const int row = rows_begin + r;
    stats_->row_blocks += static_cast<int64_t>(cols.size());
    for (int k : cols)
      if (k < rows_begin || k >= rows_end) halo.push_back(k);
    for (int k : cols) {
      const bool local = k >= rows_begin && k < rows_end;
      (local ? d_nnz : o_nnz)[r] += 1;
      if (k >= row) (local ? du_nnz : ou_nnz)[r] += 1;
    }
  }
  std::sort(halo.begin(), halo.end());
  stats_->halo_values =
      static_cast<int64_t>(std::unique(halo.begin(), halo.end()) - halo.begin()) * b;
  const PetscInt local_size = static_cast<PetscInt>(owned_rows) * b;
  GS_PETSC(MatCreate(comm_, &matrix_));
  GS_PETSC(MatSetSizes(matrix_, local_size, local_size, PETSC_DETERMINE, PETSC_DETERMINE));
  GS_PETSC(MatSetBlockSize(matrix_, b));
  GS_PETSC(MatSetType(matrix_, MATBAIJ));
  GS_PETSC(MatSetFromOptions(matrix_));  // -mat_type aij | sbaij
  GS_PETSC(MatXAIJSetPreallocation(matrix_, b, d_nnz.data(), o_nnz.data(), du_nnz.data(),
                                   ou_nnz.data()));
  MatType type = nullptr;
  GS_PETSC(MatGetType(matrix_, &type));
  // SBAIJ stores the upper triangle: the U_ik^T inserted in row k are dropped.
  if (std::string(type).find("sbaij") != std::string::npos)
    GS_PETSC(MatSetOption(matrix_, MAT_IGNORE_LOWER_TRIANGULAR, PETSC_TRUE));
  GS_PETSC(MatSetOption(matrix_, MAT_NEW_NONZERO_ALLOCATION_ERR, PETSC_TRUE));
  GS_PETSC(MatSetOption(matrix_, MAT_SYMMETRIC, PETSC_TRUE));
  GS_PETSC(MatCreateVecs(matrix_, &solution_, &rhs_));

  // 6. The KSP: CG, unpreconditioned residual, the exact-solve tolerance;
  // the PETSc options database has the last word.
  GS_PETSC(KSPCreate(comm_, &ksp_));
  GS_PETSC(KSPSetType(ksp_, KSPCG));
  GS_PETSC(KSPSetNormType(ksp_, KSP_NORM_UNPRECONDITIONED));
  GS_PETSC(KSPSetTolerances(ksp_, options.pcg_relative_tolerance, 0.0, PETSC_DEFAULT,
                            options.pcg_max_iterations));
  GS_PETSC(KSPSetFromOptions(ksp_));
  return Status::Ok();
}

Status PetscReducedSolver::Solve(double lambda, const Eigen::VectorXd& damping,
                                 core::ReducedSystem* system, Eigen::VectorXd* x,
                                 int* iterations, double /*chi2*/) {
  const int b = b_;
  const int bb = b * b;
  const int rows_begin = first_[rank_];
  const int owned_rows = first_[rank_ + 1] - rows_begin;
  const core::BlockSparseMatrix& local = system->matrix;
  using Clock = std::chrono::steady_clock;
  const Clock::time_point exchange_start = Clock::now();

  // Pack: blocks, then the rhs segment of each destination's rows.
  for (int d = 0; d < size_; ++d) {
    double* out = send_buffer_.data() + send_displs_[d];
    for (int64_t j : send_blocks_[d]) out = std::copy_n(local.StoredBlock(j), bb, out);
    std::copy_n(system->rhs.data() + static_cast<int64_t>(first_[d]) * b,
                (first_[d + 1] - first_[d]) * b, out);
  }
  GS_MPI(MPI_Alltoallv(send_buffer_.data(), send_counts_.data(), send_displs_.data(), MPI_DOUBLE,
                       recv_buffer_.data(), recv_counts_.data(), recv_displs_.data(), MPI_DOUBLE,
                       comm_));

  // Sum in ascending source rank: the same order in every run.
  std::fill(slot_values_.begin(), slot_values_.end(), 0.0);
  Eigen::VectorXd owned_rhs = Eigen::VectorXd::Zero(static_cast<int64_t>(owned_rows) * b);
  int64_t t = 0;
  for (int s = 0; s < size_; ++s) {
    const double* in = recv_buffer_.data() + recv_displs_[s];
    const int blocks = (recv_counts_[s] - owned_rows * b) / bb;
    for (int q = 0; q < blocks; ++q, ++t) {
      double* slot = slot_values_.data() + recv_slot_[t] * bb;
      for (int e = 0; e < bb; ++e) slot[e] += in[e];
      in += bb;
    }
    for (int64_t e = 0; e < owned_rhs.size(); ++e) owned_rhs[e] += in[e];
  }
  for (int r = 0; r < owned_rows; ++r) {
    double* diagonal = slot_values_.data() + diagonal_slot_[r] * bb;
    for (int c = 0; c < b; ++c)
      diagonal[c * b + c] += lambda * damping[static_cast<int64_t>(rows_begin + r) * b + c];
  }

  // Insert my rows: U_ik in row i, U_ik^T in row k.
  std::vector<double> transposed(bb);
  for (size_t s = 0; s < slot_row_.size(); ++s) {
    const PetscInt i = slot_row_[s];
    const PetscInt k = slot_col_[s];
    const double* block = slot_values_.data() + s * bb;
    if (i >= rows_begin && i < rows_begin + owned_rows)
      GS_PETSC(MatSetValuesBlocked(matrix_, 1, &i, 1, &k, block, INSERT_VALUES));
    if (k != i && k >= rows_begin && k < rows_begin + owned_rows) {
      for (int r = 0; r < b; ++r)
        for (int c = 0; c < b; ++c) transposed[c * b + r] = block[r * b + c];
      GS_PETSC(MatSetValuesBlocked(matrix_, 1, &k, 1, &i, transposed.data(), INSERT_VALUES));
    }
  }
  GS_PETSC(MatAssemblyBegin(matrix_, MAT_FINAL_ASSEMBLY));
  GS_PETSC(MatAssemblyEnd(matrix_, MAT_FINAL_ASSEMBLY));

  PetscScalar* rhs_values = nullptr;
  GS_PETSC(VecGetArray(rhs_, &rhs_values));
  std::copy_n(owned_rhs.data(), owned_rhs.size(), rhs_values);
  GS_PETSC(VecRestoreArray(rhs_, &rhs_values));
  GS_PETSC(VecSet(solution_, 0.0));
  GS_PETSC(KSPSetOperators(ksp_, matrix_, matrix_));
  const Clock::time_point ksp_start = Clock::now();
  stats_->exchange_seconds += std::chrono::duration<double>(ksp_start - exchange_start).count();
  const double ksp_cpu_start = ProcessCpuSeconds();
  GS_PETSC(KSPSolve(ksp_, rhs_, solution_));
  stats_->ksp_cpu_seconds += ProcessCpuSeconds() - ksp_cpu_start;
  const Clock::time_point gather_start = Clock::now();
  stats_->ksp_seconds += std::chrono::duration<double>(gather_start - ksp_start).count();
  stats_->solves += 1;
  if (stats_->solves == 1) {
    KSPType ksp_type = nullptr;
    PC pc = nullptr;
    PCType pc_type = nullptr;
    GS_PETSC(KSPGetType(ksp_, &ksp_type));
    GS_PETSC(KSPGetPC(ksp_, &pc));
    GS_PETSC(PCGetType(pc, &pc_type));
    stats_->ksp_type = ksp_type != nullptr ? ksp_type : "";
    stats_->pc_type = pc_type != nullptr ? pc_type : "";
  }
  KSPConvergedReason reason;
  GS_PETSC(KSPGetConvergedReason(ksp_, &reason));
  PetscInt its = 0;
  GS_PETSC(KSPGetIterationNumber(ksp_, &its));
  *iterations = static_cast<int>(its);
  stats_->ksp_iterations += its;
  if (reason < 0) {
    return Status::Numerical("PETSc KSP did not converge: " +
                             std::string(KSPConvergedReasons[reason]) + " after " +
                             std::to_string(its) + " iterations");
  }

  // Every rank gets the whole step.
  x->resize(local.num_rows());
  const PetscScalar* solution_values = nullptr;
  GS_PETSC(VecGetArrayRead(solution_, &solution_values));
  const int mpi_status =
      MPI_Allgatherv(solution_values, owned_rows * b, MPI_DOUBLE, x->data(),
                     gather_counts_.data(), gather_displs_.data(), MPI_DOUBLE, comm_);
  GS_PETSC(VecRestoreArrayRead(solution_, &solution_values));
  GS_MPI(mpi_status);
  stats_->gather_seconds += std::chrono::duration<double>(Clock::now() - gather_start).count();
  stats_->gather_bytes_sent += int64_t{8} * owned_rows * b * (size_ - 1);
  return Status::Ok();
}

}  // namespace graphslam::distributed

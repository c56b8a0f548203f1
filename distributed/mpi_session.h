// MpiSession: MPI and PETSc for the lifetime of one distributed command.
// Start() calls PetscInitialize (which initializes MPI, reads the PETSC_OPTIONS
// environment variable) and then inserts `petsc_options` ("-ksp_type cg
// -pc_type gamg", the solve's --petsc-options) into PETSc's options database;
// the destructor calls PetscFinalize (and with it MPI_Finalize).
//
// THREAD SAFETY: one session per process, created and destroyed on the main
// thread. ALLOCATION: PETSc's.
#pragma once

#include <mpi.h>

#include <memory>
#include <string>

#include "core/status.h"

namespace graphslam::distributed {

class MpiSession {
 public:
  static StatusOr<std::unique_ptr<MpiSession>> Start(const std::string& petsc_options);
  ~MpiSession();
  MpiSession(const MpiSession&) = delete;
  MpiSession& operator=(const MpiSession&) = delete;

  MPI_Comm comm() const { return MPI_COMM_WORLD; }
  int rank() const { return rank_; }
  int size() const { return size_; }

 private:
  MpiSession() = default;
  int rank_ = 0;
  int size_ = 1;
};

}  // namespace graphslam::distributed

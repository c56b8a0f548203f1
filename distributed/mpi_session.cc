#include "distributed/mpi_session.h"

#include <petscsys.h>

namespace graphslam::distributed {

StatusOr<std::unique_ptr<MpiSession>> MpiSession::Start(const std::string& petsc_options) {
  std::unique_ptr<MpiSession> session(new MpiSession());
  if (PetscInitialize(nullptr, nullptr, nullptr, nullptr) != 0)
    return Status::NotSupported("PetscInitialize failed (MPI not available?)");
  MPI_Comm_rank(MPI_COMM_WORLD, &session->rank_);
  MPI_Comm_size(MPI_COMM_WORLD, &session->size_);
  if (!petsc_options.empty() && PetscOptionsInsertString(nullptr, petsc_options.c_str()) != 0)
    return Status::InvalidArgument("--petsc-options: PETSc cannot parse '" + petsc_options + "'");
  return session;
}

MpiSession::~MpiSession() { PetscFinalize(); }

}  // namespace graphslam::distributed

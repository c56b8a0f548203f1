// Built without MPI and PETSc: no distributed solve (see the header).
#include <cstdlib>

#include "tools/distributed_solve_command.h"

namespace graphslam::tools {

StatusOr<std::unique_ptr<DistributedSolveRun>> DistributedSolveRun::Start(
    const std::string& /*petsc_options*/) {
  return Status::NotSupported(
      "this graphslam was built without MPI and PETSc (GRAPHSLAM_WITH_MPI=OFF): it cannot "
      "solve over several processes; install libopenmpi-dev and libpetsc-real-dev and rebuild");
}

}  // namespace graphslam::tools

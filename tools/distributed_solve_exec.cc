// Built with MPI and PETSc, linked into `graphslam`: the solve over ranks
// lives in the sibling binary graphslam-mpi (tools/CMakeLists.txt says why),
// so Start replaces this process by graphslam-mpi with the same arguments.
// execv keeps the pid and the environment the MPI launcher set, so the
// sibling joins the run as this process would have. Start returns only when
// the sibling is missing or cannot be executed.
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "tools/distributed_solve_command.h"

namespace graphslam::tools {

StatusOr<std::unique_ptr<DistributedSolveRun>> DistributedSolveRun::Start(
    const std::string& /*petsc_options*/) {
  std::error_code error;
  const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe", error);
  if (error) return Status::IOError("/proc/self/exe: " + error.message());
  const std::filesystem::path sibling = self.parent_path() / "graphslam-mpi";
  if (sibling == self) {
    return Status::NotSupported(self.string() + " was linked without the distributed solve");
  }
  // The arguments as the launcher gave them: NUL-terminated strings.
  std::ifstream cmdline("/proc/self/cmdline", std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(cmdline)),
                          std::istreambuf_iterator<char>());
  std::vector<char*> argv;
  for (size_t at = 0; at < bytes.size(); at += std::strlen(bytes.c_str() + at) + 1)
    argv.push_back(const_cast<char*>(bytes.c_str() + at));
  if (argv.empty()) return Status::IOError("/proc/self/cmdline: no arguments");
  argv.push_back(nullptr);
  execv(sibling.c_str(), argv.data());
  return Status::NotSupported("cannot run " + sibling.string() +
                              " (the solve over MPI ranks; build the target graphslam_mpi): " +
                              std::strerror(errno));
}

}  // namespace graphslam::tools

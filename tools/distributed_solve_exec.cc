// Built with MPI and PETSc, linked into `graphslam`: the solve over ranks
// lives in the sibling binary graphslam-mpi (tools/CMakeLists.txt says why),
// so Start replaces this process by graphslam-mpi with the same arguments.
// execv keeps the pid and the environment the MPI launcher set, so the
// sibling joins the run as this process would have. Start returns only when
// the sibling is missing or cannot be executed. Its own path and arguments
// are read from /proc through storage's Env, as every byte on disk is.
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "storage/env.h"
#include "tools/distributed_solve_command.h"

namespace graphslam::tools {
namespace {

// The arguments as the launcher gave them: NUL-terminated strings in
// /proc/self/cmdline, whose size stat(2) gives as 0, so read to the end.
StatusOr<std::string> ReadCommandLine(storage::Env* env) {
  GS_ASSIGN_OR_RETURN(std::unique_ptr<storage::ReadableFile> file,
                      env->NewReadableFile("/proc/self/cmdline"));
  std::string bytes;
  constexpr size_t kBlock = 4096;
  for (;;) {
    const size_t kept = bytes.size();
    bytes.resize(kept + kBlock);
    GS_ASSIGN_OR_RETURN(const size_t got, file->Read(kBlock, bytes.data() + kept));
    bytes.resize(kept + got);
    if (got < kBlock) return bytes;
  }
}

}  // namespace

StatusOr<std::unique_ptr<DistributedSolveRun>> DistributedSolveRun::Start(
    const std::string& /*petsc_options*/) {
  storage::Env* const env = storage::Env::Default();
  GS_ASSIGN_OR_RETURN(const std::string self_path, env->ResolvePath("/proc/self/exe"));
  const std::filesystem::path self(self_path);
  const std::filesystem::path sibling = self.parent_path() / "graphslam-mpi";
  if (sibling == self) {
    return Status::NotSupported(self.string() + " was linked without the distributed solve");
  }
  GS_ASSIGN_OR_RETURN(const std::string bytes, ReadCommandLine(env));
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

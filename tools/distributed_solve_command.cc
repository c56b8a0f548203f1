// Built with MPI and PETSc: the distributed solve (see the header).
#include <mpi.h>

#include <cstdlib>
#include <nlohmann/json.hpp>

#include "distributed/distributed_solve.h"
#include "distributed/mpi_session.h"
#include "tools/distributed_solve_command.h"

namespace graphslam::tools {
namespace {

class MpiSolveRun : public DistributedSolveRun {
 public:
  explicit MpiSolveRun(std::unique_ptr<distributed::MpiSession> session)
      : session_(std::move(session)) {}
  int rank() const override { return session_->rank(); }
  int size() const override { return session_->size(); }
  [[noreturn]] void Abort(int exit_code) override {
    MPI_Abort(session_->comm(), exit_code);
    std::abort();  // MPI_Abort does not return
  }

  Status Solve(const core::SolverOptions& options, const storage::DiskChunkSource& store,
               core::Problem2d* problem, core::SolverSummary* summary,
               nlohmann::json* report) override {
    std::vector<int64_t> observations;
    observations.reserve(store.entries().size());
    for (const storage::ChunkStoreEntry& entry : store.entries())
      observations.push_back(entry.observations);
    distributed::DistributedSolveInfo info;
    const Status status = distributed::SolveGraphSlamDistributed(
        session_->comm(), options, store, observations, problem, summary, &info);
    (*report)["distributed"] = {{"ranks", info.ranks},
                                {"chunks_per_rank", info.chunks_per_rank},
                                {"observations_per_rank", info.observations_per_rank},
                                {"ksp_type", info.exchange.ksp_type},
                                {"pc_type", info.exchange.pc_type},
                                // Rank 0's figures (it writes the report).
                                {"bytes_sent_per_solve", info.exchange.bytes_sent_per_solve},
                                {"assembled_blocks", info.exchange.owned_blocks},
                                {"solves", info.exchange.solves},
                                {"exchange_seconds", info.exchange.exchange_seconds},
                                {"ksp_seconds", info.exchange.ksp_seconds},
                                {"gather_seconds", info.exchange.gather_seconds}};
    return status;
  }

 private:
  std::unique_ptr<distributed::MpiSession> session_;
};

}  // namespace

StatusOr<std::unique_ptr<DistributedSolveRun>> DistributedSolveRun::Start(
    const std::string& petsc_options) {
  StatusOr<std::unique_ptr<distributed::MpiSession>> session =
      distributed::MpiSession::Start(petsc_options);
  GS_RETURN_IF_ERROR(session.status());
  return std::unique_ptr<DistributedSolveRun>(
      std::make_unique<MpiSolveRun>(std::move(session).value()));
}

}  // namespace graphslam::tools

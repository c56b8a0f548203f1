// Built with MPI and PETSc: the distributed solve (see the header).
#include <mpi.h>

#include <chrono>
#include <cstdlib>
#include <nlohmann/json.hpp>
#include <thread>

#include "distributed/distributed_solve.h"
#include "distributed/mpi_session.h"
#include "storage/stop_point.h"
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

  void Barrier() override {
    MPI_Request request;
    MPI_Ibarrier(session_->comm(), &request);
    int done = 0;
    MPI_Test(&request, &done, MPI_STATUS_IGNORE);
    while (!done) {
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
      MPI_Test(&request, &done, MPI_STATUS_IGNORE);
    }
  }

  Status GatherChunkEntries(std::vector<storage::ChunkStoreEntry>* entries,
                            std::vector<storage::ChunkStoreShard>* shards) override {
    Barrier();  // the slowest shard writer, waited for without spinning
    const MPI_Comm comm = session_->comm();
    const int size = session_->size();
    const bool root = session_->rank() == 0;
    // Four integers per chunk: features, observations, bytes, CRC32C (the
    // file name is the chunk's position's).
    constexpr int kFields = 4;
    std::vector<int64_t> mine;
    for (const storage::ChunkStoreEntry& e : *entries)
      mine.insert(mine.end(), {e.features, e.observations, e.bytes, int64_t{e.crc32c}});
    int count = static_cast<int>(mine.size());
    std::vector<int> counts(root ? size : 0);
    MPI_Gather(&count, 1, MPI_INT, counts.data(), 1, MPI_INT, 0, comm);
    std::vector<int> displacements(root ? size : 0);
    int total = 0;
    for (int r = 0; r < static_cast<int>(counts.size()); ++r) {
      displacements[r] = total;
      total += counts[r];
    }
    std::vector<int64_t> all(root ? total : 0);
    if (MPI_Gatherv(mine.data(), count, MPI_INT64_T, all.data(), counts.data(),
                    displacements.data(), MPI_INT64_T, 0, comm) != MPI_SUCCESS)
      return Status::IOError("MPI_Gatherv of the chunk entries failed");
    if (!root) return Status::Ok();
    entries->clear();
    shards->clear();
    for (int r = 0; r < size; ++r) {
      shards->push_back({r, static_cast<int64_t>(entries->size()), counts[r] / kFields});
      for (int i = displacements[r]; i < displacements[r] + counts[r]; i += kFields) {
        entries->push_back({storage::ChunkStoreFileName(static_cast<int64_t>(entries->size())),
                            all[i], all[i + 1], all[i + 2], static_cast<uint32_t>(all[i + 3])});
      }
    }
    return Status::Ok();
  }

  Status Solve(const core::SolverOptions& options, const storage::DiskChunkSource& store,
               core::Problem2d* problem, core::SolverSummary* summary,
               nlohmann::json* report) override {
    std::vector<int64_t> observations;
    observations.reserve(store.entries().size());
    for (const storage::ChunkStoreEntry& entry : store.entries())
      observations.push_back(entry.observations);
    distributed::DistributedSolveInfo info;
    const std::string rank = std::to_string(session_->rank());
    const Status status = distributed::SolveGraphSlamDistributed(
        session_->comm(), options, store, observations, problem, summary, &info,
        [&rank](int iteration) {
          storage::StopPointForTests("rank " + rank + " solver_checkpoint " +
                                     std::to_string(iteration));
        });
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
    // Every rank's costs (docs/distributed.md, "Measured"): seconds of its
    // solve and where they went, and the bytes it sent.
    nlohmann::json per_rank = nlohmann::json::array();
    for (const distributed::DistributedSolveInfo::RankCosts& c : info.per_rank) {
      const distributed::ExchangeStats& e = c.exchange;
      per_rank.push_back(
          {{"solve_seconds", c.solve_seconds},
           {"reduction_seconds", e.reduction_seconds},
           {"exchange_seconds", e.exchange_seconds},
           {"ksp_seconds", e.ksp_seconds},
           {"gather_seconds", e.gather_seconds},
           {"checkpoint_seconds", c.checkpoint_seconds},
           {"passes_seconds", c.solve_seconds - e.reduction_seconds - e.exchange_seconds -
                                  e.ksp_seconds - e.gather_seconds - c.checkpoint_seconds},
           {"reductions", e.reductions},
           {"reduction_bytes_sent", e.reduction_bytes},
           {"exchange_bytes_sent", e.bytes_sent_per_solve * e.solves},
           {"gather_bytes_sent", e.gather_bytes_sent},
           {"checkpoint_bytes_sent", c.checkpoint_bytes_sent},
           {"ksp_iterations", e.ksp_iterations},
           {"halo_bytes_per_ksp_iteration", 8 * e.halo_values},
           {"halo_bytes_received", 8 * e.halo_values * e.ksp_iterations},
           {"solves", e.solves},
           {"peak_rss_bytes", c.peak_rss_bytes},
           {"cpu_seconds", c.cpu_seconds},
           {"ksp_cpu_seconds", e.ksp_cpu_seconds},
           {"assembled_blocks", e.owned_blocks}});
    }
    (*report)["distributed"]["per_rank"] = std::move(per_rank);
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

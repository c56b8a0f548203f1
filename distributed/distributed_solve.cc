#include "distributed/distributed_solve.h"

#include <chrono>
#include <thread>

#include "core/internal/chunked_solve_impl.h"
#include "distributed/chunk_assignment.h"
#include "distributed/mpi_ranks.h"

namespace graphslam::distributed {
namespace {

// Eigen fixed-size vectors of doubles, stored contiguously. The other ranks
// wait for rank 0 (which initialized the problem alone) without spinning on
// a core: MPI_Ibcast, then MPI_Test every millisecond.
template <class Vector>
void Broadcast(MPI_Comm comm, std::vector<Vector>* values) {
  static_assert(sizeof(Vector) == Vector::SizeAtCompileTime * sizeof(double));
  MPI_Request request;
  MPI_Ibcast(values->data(), static_cast<int>(values->size() * Vector::SizeAtCompileTime),
             MPI_DOUBLE, 0, comm, &request);
  int done = 0;
  MPI_Test(&request, &done, MPI_STATUS_IGNORE);
  while (!done) {
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
    MPI_Test(&request, &done, MPI_STATUS_IGNORE);
  }
}

}  // namespace

Status SolveGraphSlamDistributed(MPI_Comm comm, const core::SolverOptions& options,
                                 const core::ChunkSource& chunks,
                                 const std::vector<int64_t>& chunk_observations,
                                 core::Problem2d* problem, core::SolverSummary* summary,
                                 DistributedSolveInfo* info) {
  MpiRanks ranks(comm);
  if (options.checkpoint_callback || options.resume_from != nullptr ||
      options.candidate_store != nullptr) {
    return Status::NotSupported(
        "the distributed solve has no checkpoints, --resume or candidate store yet");
  }
  if (static_cast<int64_t>(chunk_observations.size()) != chunks.NumChunks()) {
    return Status::InvalidArgument("chunk observation counts: " +
                                   std::to_string(chunk_observations.size()) + " for " +
                                   std::to_string(chunks.NumChunks()) + " chunks");
  }
  // 1. One start for all ranks.
  Broadcast(comm, &problem->poses);
  Broadcast(comm, &problem->features);

  // 2. My chunks.
  const std::vector<int> owner = AssignChunks(chunk_observations, ranks.size());
  std::vector<int64_t> mine;
  info->ranks = ranks.size();
  info->chunks_per_rank.assign(ranks.size(), 0);
  info->observations_per_rank.assign(ranks.size(), 0);
  for (size_t k = 0; k < owner.size(); ++k) {
    info->chunks_per_rank[owner[k]] += 1;
    info->observations_per_rank[owner[k]] += chunk_observations[k];
    if (owner[k] == ranks.rank()) mine.push_back(static_cast<int64_t>(k));
  }
  const SubsetChunkSource my_chunks(&chunks, mine);

  // 3. The solve.
  Status status = core::internal::SolveChunkedWith<core::Space2d>(
      options, my_chunks, problem, summary, nullptr, {}, &ranks);
  status = ranks.Agree(std::move(status));
  info->exchange = ranks.stats();
  GS_RETURN_IF_ERROR(status);

  // 4. Every feature's estimate from the rank that owns its chunk.
  std::vector<uint8_t> owned(problem->features.size(), 0);
  core::ObservationChunk chunk;
  Status loaded = Status::Ok();
  for (int64_t k = 0; k < my_chunks.NumChunks() && loaded.ok(); ++k) {
    loaded = my_chunks.Load(k, &chunk);
    if (loaded.ok())
      for (int32_t g : chunk.features) owned[g] = 1;
  }
  GS_RETURN_IF_ERROR(ranks.Agree(std::move(loaded)));
  static_assert(sizeof(core::Point2) == 2 * sizeof(double));
  for (size_t g = 0; g < owned.size(); ++g)
    if (!owned[g]) problem->features[g] = core::Point2::Zero();
  MPI_Allreduce(MPI_IN_PLACE, problem->features.data(),
                static_cast<int>(2 * problem->features.size()), MPI_DOUBLE, MPI_SUM, comm);
  return Status::Ok();
}

}  // namespace graphslam::distributed

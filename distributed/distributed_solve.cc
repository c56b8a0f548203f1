#include "distributed/distributed_solve.h"

#include <sys/resource.h>

#include <chrono>
#include <utility>

#include "core/internal/chunked_solve_impl.h"
#include "distributed/checkpoint_exchange.h"
#include "distributed/chunk_assignment.h"
#include "distributed/mpi_ranks.h"

namespace graphslam::distributed {
namespace {

// Eigen fixed-size vectors of doubles, stored contiguously.
template <class Vector>
void Broadcast(MPI_Comm comm, std::vector<Vector>* values) {
  static_assert(sizeof(Vector) == Vector::SizeAtCompileTime * sizeof(double));
  BroadcastBytes(comm, values->data(), values->size() * sizeof(Vector));
}

// Every rank's costs to rank 0 (one MPI_Gather of 19 doubles per rank;
// the counts are far below 2^53, so exact).
void GatherRankCosts(MPI_Comm comm, const DistributedSolveInfo::RankCosts& mine,
                     std::vector<DistributedSolveInfo::RankCosts>* all) {
  constexpr int kValues = 19;
  const ExchangeStats& e = mine.exchange;
  const double values[kValues] = {
      static_cast<double>(e.bytes_sent_per_solve), static_cast<double>(e.owned_blocks),
      static_cast<double>(e.row_blocks),           static_cast<double>(e.solves),
      e.exchange_seconds,                          e.ksp_seconds,
      e.gather_seconds,                            static_cast<double>(e.gather_bytes_sent),
      static_cast<double>(e.ksp_iterations),       static_cast<double>(e.halo_values),
      static_cast<double>(e.reductions),           static_cast<double>(e.reduction_bytes),
      e.reduction_seconds,                         mine.solve_seconds,
      mine.checkpoint_seconds,                     static_cast<double>(mine.checkpoint_bytes_sent),
      static_cast<double>(mine.peak_rss_bytes),    mine.cpu_seconds,
      e.ksp_cpu_seconds};
  int rank = 0, size = 1;
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &size);
  std::vector<double> gathered(rank == 0 ? static_cast<size_t>(kValues) * size : 0);
  MPI_Gather(values, kValues, MPI_DOUBLE, gathered.data(), kValues, MPI_DOUBLE, 0, comm);
  all->clear();
  if (rank != 0) return;
  for (int r = 0; r < size; ++r) {
    const double* v = gathered.data() + static_cast<size_t>(kValues) * r;
    DistributedSolveInfo::RankCosts c;
    c.exchange.bytes_sent_per_solve = static_cast<int64_t>(v[0]);
    c.exchange.owned_blocks = static_cast<int64_t>(v[1]);
    c.exchange.row_blocks = static_cast<int64_t>(v[2]);
    c.exchange.solves = static_cast<int64_t>(v[3]);
    c.exchange.exchange_seconds = v[4];
    c.exchange.ksp_seconds = v[5];
    c.exchange.gather_seconds = v[6];
    c.exchange.gather_bytes_sent = static_cast<int64_t>(v[7]);
    c.exchange.ksp_iterations = static_cast<int64_t>(v[8]);
    c.exchange.halo_values = static_cast<int64_t>(v[9]);
    c.exchange.reductions = static_cast<int64_t>(v[10]);
    c.exchange.reduction_bytes = static_cast<int64_t>(v[11]);
    c.exchange.reduction_seconds = v[12];
    c.solve_seconds = v[13];
    c.checkpoint_seconds = v[14];
    c.checkpoint_bytes_sent = static_cast<int64_t>(v[15]);
    c.peak_rss_bytes = static_cast<int64_t>(v[16]);
    c.cpu_seconds = v[17];
    c.exchange.ksp_cpu_seconds = v[18];
    all->push_back(c);
  }
}

}  // namespace

Status SolveGraphSlamDistributed(MPI_Comm comm, const core::SolverOptions& options,
                                 const core::ChunkSource& chunks,
                                 const std::vector<int64_t>& chunk_observations,
                                 core::Problem2d* problem, core::SolverSummary* summary,
                                 DistributedSolveInfo* info,
                                 const std::function<void(int)>& checkpoint_durable) {
  MpiRanks ranks(comm);
  if (options.candidate_store != nullptr)
    return Status::NotSupported("the distributed solve has no candidate store");
  if (static_cast<int64_t>(chunk_observations.size()) != chunks.NumChunks()) {
    return Status::InvalidArgument("chunk observation counts: " +
                                   std::to_string(chunk_observations.size()) + " for " +
                                   std::to_string(chunks.NumChunks()) + " chunks");
  }
  // 1. One start for all ranks; a resume's replicated state from rank 0
  // (distributed/checkpoint_exchange.h). The checkpoint's features travel as
  // the start's: on rank 0 they are in the problem or in the checkpoint.
  const core::SolverCheckpoint* const root_resume =
      ranks.rank() == 0 ? options.resume_from : nullptr;
  if (root_resume != nullptr && !root_resume->features.empty())
    problem->features = root_resume->features;
  Broadcast(comm, &problem->poses);
  Broadcast(comm, &problem->features);
  core::SolverCheckpoint resume;
  const bool resuming = BroadcastCheckpoint(comm, root_resume, &resume);

  // 2. My chunks, and the features in them: the part of the state only I hold.
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
  std::vector<uint8_t> owned(problem->features.size(), 0);
  {
    core::ObservationChunk chunk;
    Status loaded = Status::Ok();
    for (int64_t k = 0; k < my_chunks.NumChunks() && loaded.ok(); ++k) {
      loaded = my_chunks.Load(k, &chunk);
      if (loaded.ok())
        for (int32_t g : chunk.features) owned[g] = 1;
    }
    GS_RETURN_IF_ERROR(ranks.Agree(std::move(loaded)));
  }

  // Checkpoints: rank 0 writes the replicated state with every rank's
  // features gathered (the caller's callback runs on rank 0 only); the
  // others learn its status. Then `checkpoint_durable` runs on every rank.
  core::SolverOptions rank_options = options;
  rank_options.resume_from =
      !resuming ? nullptr : ranks.rank() == 0 ? options.resume_from : &resume;
  rank_options.checkpoint_callback = {};
  std::function<Status(const core::SolverCheckpoint&)> write_checkpoint;
  DistributedSolveInfo::RankCosts costs;
  if (options.checkpoint_callback) {
    write_checkpoint = [&](const core::SolverCheckpoint& checkpoint) {
      const auto gather_start = std::chrono::steady_clock::now();
      core::SolverCheckpoint whole;
      GatherFeaturesToRoot(comm, owned, checkpoint.features, &whole.features);
      costs.checkpoint_seconds +=
          std::chrono::duration<double>(std::chrono::steady_clock::now() - gather_start).count();
      if (ranks.rank() != 0)
        costs.checkpoint_bytes_sent += static_cast<int64_t>(sizeof(core::Point2)) *
                                       static_cast<int64_t>(checkpoint.features.size());
      Status written = Status::Ok();
      if (ranks.rank() == 0) {
        whole.iterations = checkpoint.iterations;
        whole.trust_region_radius = checkpoint.trust_region_radius;
        whole.decrease_factor = checkpoint.decrease_factor;
        whole.initial_chi2 = checkpoint.initial_chi2;
        whole.chi2 = checkpoint.chi2;
        whole.converged = checkpoint.converged;
        whole.termination = checkpoint.termination;
        whole.poses = checkpoint.poses;
        whole.excluded = checkpoint.excluded;
        whole.kept = checkpoint.kept;
        whole.pcg = checkpoint.pcg;
        written = options.checkpoint_callback(whole);
      }
      written = ranks.Agree(std::move(written));
      if (written.ok() && checkpoint_durable) checkpoint_durable(checkpoint.iterations);
      return written;
    };
  }

  // 3. The solve.
  const auto solve_start = std::chrono::steady_clock::now();
  Status status = core::internal::SolveChunkedWith<core::Space2d>(
      rank_options, my_chunks, problem, summary, rank_options.resume_from, write_checkpoint,
      &ranks);
  costs.solve_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - solve_start).count();
  status = ranks.Agree(std::move(status));
  info->exchange = ranks.stats();
  GS_RETURN_IF_ERROR(status);
  costs.exchange = info->exchange;
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  costs.peak_rss_bytes = int64_t{usage.ru_maxrss} * 1024;  // Linux: KiB
  costs.cpu_seconds = static_cast<double>(usage.ru_utime.tv_sec + usage.ru_stime.tv_sec) +
                      1e-6 * static_cast<double>(usage.ru_utime.tv_usec + usage.ru_stime.tv_usec);
  GatherRankCosts(comm, costs, &info->per_rank);

  // 4. Every feature's estimate from the rank that owns its chunk.
  static_assert(sizeof(core::Point2) == 2 * sizeof(double));
  for (size_t g = 0; g < owned.size(); ++g)
    if (!owned[g]) problem->features[g] = core::Point2::Zero();
  MPI_Allreduce(MPI_IN_PLACE, problem->features.data(),
                static_cast<int>(2 * problem->features.size()), MPI_DOUBLE, MPI_SUM, comm);
  return Status::Ok();
}

}  // namespace graphslam::distributed

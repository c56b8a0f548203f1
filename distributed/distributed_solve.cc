#include "distributed/distributed_solve.h"

#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <utility>

#include "core/internal/chunked_solve_impl.h"
#include "distributed/checkpoint_exchange.h"
#include "distributed/chunk_assignment.h"
#include "distributed/feature_ownership.h"
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

// 2. The chunks this rank solves (contiguous, balanced observation counts;
// distributed/chunk_assignment.h), and every rank's share in `info`.
std::vector<int64_t> AssignMyChunks(const std::vector<int64_t>& chunk_observations,
                                    const MpiRanks& ranks, DistributedSolveInfo* info) {
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
  return mine;
}

// 3. My features' start (the checkpoint's on a resume) from rank 0: the
// shared ones broadcast, my own sent. Rank 0 keeps the store-sized array
// (the start of the features in no chunk, the checkpoints, the result) and
// returns it; the other ranks release theirs and return an empty one.
std::vector<core::Point2> ScatterFeatureStart(MPI_Comm comm, bool root,
                                              const FeatureOwnership& ownership,
                                              const FeatureExchange& exchange,
                                              const core::SolverCheckpoint* root_resume,
                                              core::Problem2d* problem) {
  std::vector<core::Point2> global;
  if (root) {
    global = std::move(problem->features);
    if (root_resume != nullptr && !root_resume->features.empty()) global = root_resume->features;
  } else {
    problem->features = {};
    problem->feature_ids = {};
    problem->feature_initialized = {};
  }
  const int64_t shared = static_cast<int64_t>(ownership.shared.size());
  std::vector<core::Point2> local(static_cast<size_t>(ownership.num_local()),
                                  core::Point2::Zero());
  std::vector<core::Point2> shared_values(static_cast<size_t>(shared));
  if (root)
    for (int64_t i = 0; i < shared; ++i) shared_values[i] = global[ownership.shared[i]];
  Broadcast(comm, &shared_values);
  std::copy(shared_values.begin(), shared_values.end(), local.begin());
  exchange.Scatter(global, &local);
  problem->features = std::move(local);
  return global;
}

// 3 (resume). The partition of the interrupted solve, in my local numbering:
// the shared flags (every rank needs them: kept features are numbered in the
// reduced system) broadcast, my own sent.
void ScatterResumeFlags(MPI_Comm comm, bool root, const FeatureOwnership& ownership,
                        const FeatureExchange& exchange, const core::SolverCheckpoint* root_resume,
                        core::SolverCheckpoint* resume) {
  const int64_t shared = static_cast<int64_t>(ownership.shared.size());
  resume->excluded.assign(static_cast<size_t>(ownership.num_local()), 1);
  resume->kept.assign(static_cast<size_t>(ownership.num_local()), 0);
  std::vector<uint8_t> flags(static_cast<size_t>(2 * shared));
  if (root) {
    for (int64_t i = 0; i < shared; ++i) {
      flags[2 * i] = root_resume->excluded[ownership.shared[i]];
      flags[2 * i + 1] = root_resume->kept[ownership.shared[i]];
    }
  }
  BroadcastBytes(comm, flags.data(), flags.size());
  for (int64_t i = 0; i < shared; ++i) {
    resume->excluded[i] = flags[2 * i];
    resume->kept[i] = flags[2 * i + 1];
  }
  const std::vector<uint8_t> none;
  exchange.Scatter(root ? root_resume->excluded : none, &resume->excluded);
  exchange.Scatter(root ? root_resume->kept : none, &resume->kept);
}

// Checkpoints: every rank's own features and flags go to rank 0, which
// writes the whole state (the caller's callback runs on rank 0 only); the
// others learn its status. Then `checkpoint_durable` runs on every rank.
// Rank 0 lends its store-sized feature array (`global`) to each checkpoint
// and gets it back.
class CheckpointGather {
 public:
  CheckpointGather(bool root, int64_t num_features, MpiRanks* ranks,
                   const FeatureExchange* exchange,
                   std::function<Status(const core::SolverCheckpoint&)> write,
                   const std::function<void(int)>* durable, std::vector<core::Point2>* global,
                   DistributedSolveInfo::RankCosts* costs)
      : root_(root),
        num_features_(num_features),
        ranks_(ranks),
        exchange_(exchange),
        write_(std::move(write)),
        durable_(durable),
        global_(global),
        costs_(costs) {}

  Status Write(const core::SolverCheckpoint& checkpoint) {
    const auto gather_start = std::chrono::steady_clock::now();
    if (root_ && whole_.excluded.empty()) {
      // A feature in no chunk: unobserved, at its start, as in one process.
      whole_.excluded.assign(static_cast<size_t>(num_features_), 1);
      whole_.kept.assign(static_cast<size_t>(num_features_), 0);
    }
    whole_.features = std::move(*global_);
    exchange_->Gather(checkpoint.features, &whole_.features);
    exchange_->Gather(checkpoint.excluded, &whole_.excluded);
    exchange_->Gather(checkpoint.kept, &whole_.kept);
    costs_->checkpoint_seconds +=
        std::chrono::duration<double>(std::chrono::steady_clock::now() - gather_start).count();
    if (!root_)
      costs_->checkpoint_bytes_sent +=
          exchange_->owned() * static_cast<int64_t>(sizeof(core::Point2) + 2);
    Status written = Status::Ok();
    if (root_) {
      whole_.iterations = checkpoint.iterations;
      whole_.trust_region_radius = checkpoint.trust_region_radius;
      whole_.decrease_factor = checkpoint.decrease_factor;
      whole_.initial_chi2 = checkpoint.initial_chi2;
      whole_.chi2 = checkpoint.chi2;
      whole_.converged = checkpoint.converged;
      whole_.termination = checkpoint.termination;
      whole_.poses = checkpoint.poses;
      whole_.pcg = checkpoint.pcg;
      written = write_(whole_);
    }
    *global_ = std::move(whole_.features);
    written = ranks_->Agree(std::move(written));
    if (written.ok() && *durable_) (*durable_)(checkpoint.iterations);
    return written;
  }

 private:
  bool root_;
  int64_t num_features_;
  MpiRanks* ranks_;
  const FeatureExchange* exchange_;
  std::function<Status(const core::SolverCheckpoint&)> write_;
  const std::function<void(int)>* durable_;
  std::vector<core::Point2>* global_;
  DistributedSolveInfo::RankCosts* costs_;
  core::SolverCheckpoint whole_;  // rank 0: the store-sized arrays, kept between checkpoints
};

// This process's peak resident set size and CPU seconds so far (getrusage).
void MeasureProcess(DistributedSolveInfo::RankCosts* costs) {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  costs->peak_rss_bytes = int64_t{usage.ru_maxrss} * 1024;  // Linux: KiB
  costs->cpu_seconds = static_cast<double>(usage.ru_utime.tv_sec + usage.ru_stime.tv_sec) +
                       1e-6 * static_cast<double>(usage.ru_utime.tv_usec + usage.ru_stime.tv_usec);
}

// 5. The store-wide counts (the solve's are of my local arrays): a shared
// feature's flags are on every rank, my own are mine, a feature in no chunk
// (`outside`) is unobserved.
void CountStoreFeatures(MPI_Comm comm, int64_t shared, int64_t outside, int64_t num_features,
                        core::SolverSummary* summary) {
  const std::vector<uint8_t>& excluded = summary->excluded;
  int64_t own_excluded = std::count(excluded.begin() + shared, excluded.end(), 1);
  MPI_Allreduce(MPI_IN_PLACE, &own_excluded, 1, MPI_INT64_T, MPI_SUM, comm);
  const int64_t all_excluded =
      std::count(excluded.begin(), excluded.begin() + shared, 1) + own_excluded + outside;
  summary->unobserved_features = outside;
  summary->excluded_features = all_excluded - outside;
  summary->eliminated_features = num_features - all_excluded - summary->kept_features;
}

// 6. Every feature's estimate and flag from the rank that owns it, on rank 0
// (into its store-sized `global`, which becomes problem->features); the
// others end with none.
void GatherResult(bool root, int64_t num_features, const FeatureExchange& exchange,
                  std::vector<core::Point2>* global, core::Problem2d* problem,
                  core::SolverSummary* summary) {
  std::vector<uint8_t> all_flags;
  if (root) all_flags.assign(static_cast<size_t>(num_features), 1);
  exchange.Gather(summary->excluded, &all_flags);
  exchange.Gather(problem->features, global);
  summary->excluded = std::move(all_flags);
  problem->features = std::move(*global);
}

}  // namespace

Status SolveGraphSlamDistributed(MPI_Comm comm, const core::SolverOptions& options,
                                 const core::ChunkSource& chunks,
                                 const std::vector<int64_t>& chunk_observations,
                                 core::Problem2d* problem, core::SolverSummary* summary,
                                 DistributedSolveInfo* info,
                                 const std::function<void(int)>& checkpoint_durable) {
  MpiRanks ranks(comm);
  const bool root = ranks.rank() == 0;
  if (options.candidate_store != nullptr)
    return Status::NotSupported("the distributed solve has no candidate store");
  if (static_cast<int64_t>(chunk_observations.size()) != chunks.NumChunks()) {
    return Status::InvalidArgument("chunk observation counts: " +
                                   std::to_string(chunk_observations.size()) + " for " +
                                   std::to_string(chunks.NumChunks()) + " chunks");
  }
  // 1. One start for all ranks: rank 0's poses and feature count; a
  // resume's scalars and poses (distributed/checkpoint_exchange.h).
  Broadcast(comm, &problem->poses);
  int64_t num_features = static_cast<int64_t>(problem->features.size());
  BroadcastBytes(comm, &num_features, sizeof(num_features));
  const core::SolverCheckpoint* const root_resume = root ? options.resume_from : nullptr;
  core::SolverCheckpoint resume;
  const bool resuming = BroadcastCheckpoint(comm, root_resume, &resume);

  // 2. My chunks, and the features in them, numbered locally
  // (distributed/feature_ownership.h).
  const SubsetChunkSource my_chunks(&chunks, AssignMyChunks(chunk_observations, ranks, info));
  FeatureOwnership ownership;
  GS_RETURN_IF_ERROR(ranks.Agree(BuildFeatureOwnership(
      comm, my_chunks, options.max_eliminated_observations, &ownership)));
  const OwnedFeatureChunkSource local_chunks(&my_chunks, &ownership);
  const int64_t shared = static_cast<int64_t>(ownership.shared.size());
  const int64_t outside = num_features - ownership.observed_features;
  ranks.SetFeatureLayout(shared, outside);
  const FeatureExchange exchange(comm, &ownership);

  // 3. My features' start and, on a resume, my part of its partition.
  std::vector<core::Point2> global = ScatterFeatureStart(
      comm, root, ownership, exchange, resuming ? root_resume : nullptr, problem);
  if (resuming) ScatterResumeFlags(comm, root, ownership, exchange, root_resume, &resume);

  core::SolverOptions rank_options = options;
  rank_options.resume_from = resuming ? &resume : nullptr;
  rank_options.checkpoint_callback = {};
  DistributedSolveInfo::RankCosts costs;
  CheckpointGather gather(root, num_features, &ranks, &exchange, options.checkpoint_callback,
                          &checkpoint_durable, &global, &costs);
  std::function<Status(const core::SolverCheckpoint&)> write_checkpoint;
  if (options.checkpoint_callback)
    write_checkpoint = [&gather](const core::SolverCheckpoint& c) { return gather.Write(c); };

  // 4. The solve, over my chunks and my features.
  const auto solve_start = std::chrono::steady_clock::now();
  Status status = core::internal::SolveChunkedWith<core::Space2d>(
      rank_options, local_chunks, problem, summary, rank_options.resume_from, write_checkpoint,
      &ranks);
  costs.solve_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - solve_start).count();
  status = ranks.Agree(std::move(status));
  info->exchange = ranks.stats();
  GS_RETURN_IF_ERROR(status);
  costs.exchange = info->exchange;
  MeasureProcess(&costs);
  GatherRankCosts(comm, costs, &info->per_rank);

  CountStoreFeatures(comm, shared, outside, num_features, summary);
  GatherResult(root, num_features, exchange, &global, problem, summary);
  return Status::Ok();
}

}  // namespace graphslam::distributed

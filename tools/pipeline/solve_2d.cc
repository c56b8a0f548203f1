// The 2-D hooks of the solve path (tools/pipeline/solve_path.h: Hooks2d), in
// the order RunSolvePath calls them:
//
//   ReadInput        LockStore (the locks, and a FILE ingested into
//                    --workdir), then a chunk store (poses; observations
//                    loaded unless it streams) or a file in its format
//   InitializeGuess  Table 1, or as-given's check
//   ConfigureChunks  the chunk source, the --memory-limit budget
//   ImproveGuess     TryOdometry (--initialization auto: the solve from
//                    Table 1's guess, kept if it converged), then ImproveGuess
//                    (incremental, progressive or pose-graph initialization)
//   PrepareCheckpoints  streaming scratch files beside the checkpoint
//   Optimize         association, the MPI solve, or SolveGraphSlam
//   AddReport, PrintDetails  the report's and summary's 2-D parts
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/graphslam_solver.h"
#include "core/initialization.h"
#include "core/information_repair.h"
#include "core/logging.h"
#include "core/unidentified_features.h"
#include "partition/association/association_driver.h"
#include "partition/initialization/gps_segment_alignment.h"
#include "partition/ingest/in_memory_chunk_source.h"
#include "partition/initialization/incremental_initialization.h"
#include "partition/initialization/pose_graph_initialization.h"
#include "partition/initialization/progressive_initialization.h"
#include "partition/initialization/sampled_incremental_initialization.h"
#include "storage/candidate_file.h"
#include "storage/chunk_store.h"
#include "storage/directory_lock.h"
#include "storage/env.h"
#include "storage/feature_id_file.h"
#include "storage/features_csv_writer.h"
#include "storage/g2o_writer.h"
#include "storage/solver_checkpoint.h"
#include "storage/store_directory.h"
#include "storage/tum_writer.h"
#include "tools/association_report.h"
#include "tools/association_store.h"
#include "tools/exit_codes.h"
#include "tools/memory_budget.h"
#include "tools/out_of_core_solve.h"
#include "tools/pipeline/solve_path.h"
#include "tools/pipeline/solve_run.h"
#include "tools/progress_display.h"
#include "tools/resource_usage.h"
#include "tools/solve_report.h"

namespace graphslam::tools {
namespace {

// --initialization auto abandons the odometry start at a step with rho below
// this: the classic trust-region bound of a poor quadratic model
// (docs/benchmarks.md gives the lowest rho of each dataset's steps).
constexpr double kAutoAbandonRho = 0.25;

// What a 2-D solve holds beyond SolveState (tools/pipeline/solve_path.h), in
// the order the steps fill it.
struct Solve2d : SolveState<core::Space2d> {
  storage::DirectoryLock lock;  // held to the end
  std::string store_path;       // the store solved from ("": a file in memory)
  std::unique_ptr<storage::DiskChunkSource> store;
  storage::MrclamReadStats mrclam_stats;  // an MRCLAM input's skipped records
  partition::IncrementalSummary incremental_summary;

  std::unique_ptr<partition::InMemoryChunkSource> in_memory;
  std::unique_ptr<storage::CandidateFile> candidate_file;
  std::unique_ptr<storage::FeatureIdFile> id_file;

  // --initialization auto's solve from odometry.
  bool probe = false, probe_solved = false;
  nlohmann::json probe_report;
  nlohmann::json sampled_report;  // the streaming start (StartFromSampledFeatures)
  int64_t sample_observations = -1;  // its cap under --memory-limit (-1: none)
  double probe_seconds = 0, probe_cpu_seconds = 0;

  partition::AssociationOptions association;
  partition::AssociationSummary association_summary;
  nlohmann::json distributed_report = nlohmann::json::object();
};

// Appends every observation of `chunks`, in chunk order, to problem->observations.
// Each feature's observations keep their input order (chunks are
// feature-complete), which is all progressive initialization and the
// in-memory chunking depend on, so they behave as on the original input.
Status LoadObservations(const core::ChunkSource& chunks, core::Problem2d* problem) {
  core::ObservationChunk chunk;
  for (int64_t k = 0; k < chunks.NumChunks(); ++k) {
    GS_RETURN_IF_ERROR(chunks.Load(k, &chunk));
    problem->observations.insert(problem->observations.end(), chunk.observations.begin(),
                                 chunk.observations.end());
  }
  return Status::Ok();
}

// --initialization as-given (after ValidateProblem, so indices are in range):
// the input must give every pose and every observed feature a guess (a g2o
// file with all its VERTEX lines, e.g. one written by `graphslam solve -o`),
// since nothing will be filled in.
Status CheckEveryGuessGiven(const core::Problem2d& problem) {
  const std::string needs =
      " has no initial guess in the input; --initialization as-given needs a guess (VERTEX "
      "line) for every pose and observed feature, expected e.g. a graph written by "
      "`graphslam solve -o`";
  for (int32_t i = 0; i < problem.num_poses(); ++i) {
    if (problem.pose_initialized[i] != 0) continue;
    // Built by append: GCC 12 gives a false -Wrestrict on `":" + std::string` at -O3.
    std::string where = problem.source;
    if (problem.pose_lines[i] > 0) {
      where.push_back(':');
      where.append(std::to_string(problem.pose_lines[i]));
    }
    return Status::InvalidArgument(where + ": pose " + std::to_string(problem.pose_ids[i]) +
                                   needs);
  }
  std::vector<uint8_t> observed(problem.features.size(), 0);
  for (const core::Observation& o : problem.observations) observed[o.feature] = 1;
  for (int32_t j = 0; j < problem.num_features(); ++j) {
    if (observed[j] == 0 || problem.feature_initialized[j] != 0) continue;
    return Status::InvalidArgument(problem.source + ": feature " +
                                   std::to_string(problem.feature_ids[j]) + needs);
  }
  return Status::Ok();
}

// Locks (storage/directory_lock.h), held to the end: the workdir, or a store
// this solve writes into (STORE/checkpoint.json, an --associate rewrite),
// exclusively; a store it only reads, shared. A second writer fails here,
// naming the holder's pid. --workdir: a FILE goes through a chunk store in
// DIR (bounded-memory ingest).
// The bytes of the store's problem file (manifest; 0 for version 1 stores).
int64_t ProblemFileBytes(const storage::DiskChunkSource& store) {
  for (const storage::ChunkStoreFile& file : store.files())
    if (file.path == storage::kChunkStoreProblemName) return file.bytes;
  return 0;
}

// The most observations one chunk of the store holds (a chunk in flight).
int64_t LargestChunk(const storage::DiskChunkSource& store) {
  int64_t largest = 0;
  for (const storage::ChunkStoreEntry& entry : store.entries())
    largest = std::max(largest, entry.observations);
  return largest;
}

Status LockStore(const SolveRun& run, Solve2d& s) {
  const SolveCommandOptions& options = run.options;
  s.store_path = options.input;
  if (storage::IsChunkStore(options.input)) {
    // Under mpirun rank 0 alone writes (STORE/checkpoint.json) and holds
    // the lock for the job; the other ranks only read and take none (a
    // shared lock of theirs would block rank 0's exclusive one).
    if (!run.root) return Status::Ok();
    const bool writes = options.checkpoint.empty() || options.associate;
    GS_ASSIGN_OR_RETURN(s.lock, storage::DirectoryLock::Acquire(
                                    options.input, writes ? storage::DirectoryLock::Mode::kExclusive
                                                          : storage::DirectoryLock::Mode::kShared));
    // Under the exclusive lock a temporary file in a store of ours is one a
    // killed writer left (a checkpoint's): nobody will rename it.
    if (writes && storage::CheckStoreDirectory(options.input).ok())
      GS_RETURN_IF_ERROR(storage::RemoveStaleTemporaries(storage::Env::Default(), options.input,
                                                         /*recursive=*/true));
    return Status::Ok();
  }
  if (options.workdir.empty()) return Status::Ok();
  // A folder that is not ours is refused before anything is written.
  GS_ASSIGN_OR_RETURN(s.lock,
                      storage::OpenStoreForWriting(storage::Env::Default(), options.workdir));
  s.store_path = options.workdir;
  // --resume reuses the store its checkpoint was made on, if still current
  // (the same input: size and CRC32C, not the mtime).
  if (options.resume && WorkdirStoreIsCurrent(options.input, options.workdir))
    return storage::RemoveStaleTemporaries(storage::Env::Default(), options.workdir,
                                           /*recursive=*/true);
  return IngestIntoWorkdir(options.input, options.format, options.robot, options.workdir,
                           options.chunk_observations, run.request.memory_limit_bytes,
                           options.resume);
}

// A chunk store (graphslam ingest) is its pose-only native log, and the solve
// streams its chunks from disk. Its observations are also loaded back into
// the problem, for the in-memory initialization and the report, unless the
// store is large enough to stream: above the streaming thresholds, or above
// the streaming start's sample budget B, where the sampled start solves a
// part of the observations and the in-memory one would solve them all for
// the same optimum (docs/out_of_core.md, "Solving").
Status ReadStore(const SolveRun& run, Solve2d& s) {
  const SolveCommandOptions& options = run.options;
  GS_ASSIGN_OR_RETURN(s.store, storage::DiskChunkSource::Open(s.store_path));
  s.num_observations = s.store->total_observations();
  partition::SampledInitializationOptions sampled;
  sampled.budget_observations = options.sample_observations;
  // --associate merges in memory (then rewrites the store): never streams.
  const auto streams = [&](int64_t poses) {
    return !options.associate && (poses > options.streaming_poses ||
                                  s.num_observations > options.streaming_observations ||
                                  s.num_observations > partition::SampleBudget(sampled, poses));
  };
  // A limit is checked before the problem file is read: its poses and
  // features counted without parsing, the observations and chunks from the manifest
  // (ConfigureSolver checks the same figures again).
  if (run.request.memory_limit_bytes > 0) {
    GS_ASSIGN_OR_RETURN(
        const RecordCounts counts,
        CountPoseAndFeatureRecords(s.store_path + "/" + storage::kChunkStoreProblemName));
    GS_RETURN_IF_ERROR(BudgetSolve(run.request.memory_limit_bytes,
                                   SolveSize{counts.poses, counts.features, s.num_observations,
                                             LargestChunk(*s.store), streams(counts.poses),
                                             ProblemFileBytes(*s.store)},
                                   1)
                           .status());
  }
  // Under mpirun only rank 0 holds every feature; the others get their own
  // from it (docs/distributed.md, "Features on ranks").
  GS_ASSIGN_OR_RETURN(s.problem, storage::ReadChunkStoreProblem(s.store_path, run.root));
  s.streaming = streams(s.problem.num_poses());
  if (s.streaming) {
    GS_LOG(INFO, "streaming mode: %d poses, %lld observations stay on disk; initial guess "
           "from a feature sample",
           s.problem.num_poses(), static_cast<long long>(s.num_observations));
    return Status::Ok();
  }
  // Under mpirun rank 0 loads them for the initialization; its start is broadcast.
  if (!run.root) return Status::Ok();
  return LoadObservations(*s.store, &s.problem);
}

Status ReadFile(const SolveRun& run, const DetectedInput& file, Solve2d& s) {
  const SolveCommandOptions& options = run.options;
  storage::MrclamOptions mrclam;
  mrclam.robot = options.robot;
  mrclam.ignore_barcodes = options.ignore_barcodes;
  GS_ASSIGN_OR_RETURN(s.problem,
                      storage::ReadProblem(options.input, file.format, mrclam, &s.mrclam_stats,
                                           options.repair_information ? &s.repairs : nullptr));
  const core::UnidentifiedObservations unidentified =
      core::CountUnidentifiedObservations(s.problem);
  if (unidentified.count > 0 && !options.associate) {
    return Status::NotSupported(
        options.input + ":" + std::to_string(unidentified.first_line) + ": " +
        std::to_string(unidentified.count) +
        " observations have no feature id (unknown correspondence); expected ids, or "
        "--associate to find the correspondences");
  }
  s.format_name = storage::InputFormatName(file.format);
  return Status::Ok();
}

Status ReadInput(const SolveRun& run, const DetectedInput* file, Solve2d& s) {
  GS_RETURN_IF_ERROR(LockStore(run, s));
  if (storage::IsChunkStore(s.store_path)) {
    GS_RETURN_IF_ERROR(ReadStore(run, s));
  } else {
    GS_CHECK(file != nullptr);  // RunSolve detects every input that is not a store
    GS_RETURN_IF_ERROR(ReadFile(run, *file, s));
  }
  if (!s.streaming) s.num_observations = static_cast<int64_t>(s.problem.observations.size());
  s.read_seconds = SecondsSince(run.start);
  return Status::Ok();
}

// Table 1 and connectivity. --initialization as-given only checks: the
// input's guess is the start, bit for bit. (Streaming: the ingest
// initialized and checked with every observation.)
Status InitializeGuess(const SolveRun& run, Solve2d& s) {
  const SolveClock::time_point initialize_start = SolveClock::now();
  if (!s.streaming && run.root) {
    if (run.request.initialization == Initialization::kAsGiven) {
      GS_RETURN_IF_ERROR(core::ValidateProblem(s.problem));
      GS_RETURN_IF_ERROR(CheckEveryGuessGiven(s.problem));
    } else {
      GS_RETURN_IF_ERROR(core::InitializeProblem(&s.problem));
    }
  }
  s.initialize_seconds = SecondsSince(initialize_start);
  return Status::Ok();
}

// The chunks (the store, or cut from the problem in memory) and what the
// --memory-limit budget allows: the chunks in flight and CHOLMOD's factor.
Status ConfigureChunks(const SolveRun& run, Solve2d& s) {
  const SolveCommandOptions& options = run.options;
  partition::ChunkingOptions chunking;
  chunking.max_observations_per_chunk = options.chunk_observations;
  if (!s.store) s.in_memory = std::make_unique<partition::InMemoryChunkSource>(s.problem, chunking);
  s.chunks = s.store ? static_cast<const core::ChunkSource*>(s.store.get()) : s.in_memory.get();
  const SolveSize size{s.problem.num_poses(), s.problem.num_features(), s.num_observations,
                       s.store ? LargestChunk(*s.store) : options.chunk_observations,
                       s.streaming, s.store ? ProblemFileBytes(*s.store) : 0};
  const int default_in_flight = s.solver.max_chunks_in_flight;
  GS_ASSIGN_OR_RETURN(const SolveBudget budget,
                      BudgetSolve(run.request.memory_limit_bytes, size, default_in_flight));
  s.solver.max_chunks_in_flight = budget.chunks_in_flight;
  s.sample_observations = budget.sample_observations;
  // The factor's values (8 lnz, what the choice counts) come with its
  // indices, the CSC copy of S it is made from and CHOLMOD's workspace.
  if (run.request.memory_limit_bytes > 0)
    s.solver.auto_cholmod_max_factor_bytes =
        std::min(s.solver.auto_cholmod_max_factor_bytes,
                 budget.factor_bytes / kCholmodBytesPerFactorByte);
  // --solver cholmod: its factor's size from the analysis, before it is made.
  if (run.request.memory_limit_bytes > 0 &&
      s.solver.linear_solver == core::LinearSolverType::kCholmod)
    s.solver.cholmod_factor_check = [limit = run.request.memory_limit_bytes, size,
                                     default_in_flight](double factor_bytes) {
      return CheckCholmodFactor(limit, size, default_in_flight, factor_bytes);
    };
  return Status::Ok();
}

// --initialization auto: the full solve from the Table 1 guess, abandoned at
// its first step whose model failed (rho < kAutoAbandonRho on a step that
// meant to matter, core/levenberg_marquardt.h); kept if it converged, else
// (abandoned, or stopped by --max-iterations) the restart. Most pose graphs
// converge from their odometry in a few well-modelled steps; a start outside
// the optimum's basin shows it within its first steps, and the solve restarts
// from the Table 1 guess with incremental initialization. Not with
// checkpoints (a probe's checkpoint would resume the wrong solve),
// --associate, streaming or under mpirun (a store's ranks start
// incrementally, as one process does).
// The initializers solve sub-problems (pose-only, prefixes, windows) whose
// factors differ from the whole problem's: --solver cholmod's factor check
// (tools/memory_budget.h) is for the whole problem's solves, the odometry
// probe and the final one, so that the limit it names holds the factor
// they make.
core::SolverOptions InitializerOptions(const core::SolverOptions& solver) {
  core::SolverOptions options = solver;
  options.cholmod_factor_check = nullptr;
  return options;
}

Status TryOdometry(const SolveRun& run, Solve2d& s) {
  s.probe = run.request.initialization == Initialization::kAuto && !s.resuming && !s.streaming &&
            s.checkpoint_path.empty() && !run.options.associate && !run.distributed &&
            run.options.max_iterations > 0;
  const SolveClock::time_point probe_start = SolveClock::now();
  const double probe_cpu_start = ProcessCpuSeconds();
  if (s.probe) {
    const std::vector<core::Pose2> guess_poses = s.problem.poses;
    const std::vector<core::Point2> guess_features = s.problem.features;
    core::SolverOptions probe_options = s.solver;
    probe_options.abandon_below_rho = kAutoAbandonRho;
    const Status status = core::SolveGraphSlam(probe_options, *s.chunks, &s.problem, &s.summary);
    if (!status.ok() && !status.IsNumerical()) return status;
    // Kept only when it converged: a probe stopped by --max-iterations
    // (never abandoned, never converged) is no answer either. chi2 of the
    // input's own estimate (Table 1 fills only what it lacks) is its start.
    s.probe_solved = status.ok() && s.summary.converged;
    s.input_chi2 = s.summary.initial_chi2;
    s.probe_report = {{"iterations", s.summary.iterations},
                      {"final_chi2", s.summary.final_chi2},
                      {"termination", status.ok() ? s.summary.termination : status.ToString()},
                      {"seconds", SecondsSince(probe_start)}};
    if (!s.probe_solved) {
      GS_LOG(INFO, "initialization auto: the solve from odometry ended unconverged after %d "
             "iterations (%s, chi2 %.6g): incremental initialization", s.summary.iterations,
             status.ok() ? s.summary.termination.c_str() : status.ToString().c_str(),
             s.summary.final_chi2);
      s.problem.poses = guess_poses;
      s.problem.features = guess_features;
      s.summary = core::SolverSummary();
    }
  }
  s.probe_seconds = SecondsSince(probe_start);
  s.probe_cpu_seconds = ProcessCpuSeconds() - probe_cpu_start;
  return Status::Ok();
}

// The pose-graph initializer (--initialization pose-graph, in memory or
// streaming). It first puts the
// dead reckoning onto the GPS fixes, segment by segment: far from them the
// pose-only LM creeps (docs/benchmarks.md). Without GPS nothing moves.
Status StartFromPoseGraph(const Solve2d& s, core::Problem2d* problem) {
  const partition::GpsAlignmentSummary aligned = partition::AlignOdometryToGps(problem);
  GS_LOG(INFO, "GPS alignment: %lld chains, %lld segments, %lld poses moved",
         static_cast<long long>(aligned.chains), static_cast<long long>(aligned.segments),
         static_cast<long long>(aligned.poses_moved));
  partition::PoseGraphInitializationSummary pose_graph;
  GS_RETURN_IF_ERROR(partition::InitializeFromPoseGraph(InitializerOptions(s.solver), 20,
                                                       *s.chunks, problem, &pose_graph));
  GS_LOG(INFO, "pose-graph initialization: %d iterations, pose-only chi2 %.6g -> %.6g, %lld "
         "features re-placed", pose_graph.iterations, pose_graph.initial_chi2,
         pose_graph.final_chi2, static_cast<long long>(pose_graph.placed_features));
  return Status::Ok();
}

// Streaming mode parks the feature ids beside the checkpoint from the start
// on (PrepareCheckpoints below; the sampled start names its features by
// index), so that their 8 B per feature are not held through the start's
// stages either. Once per solve; not under mpirun.
Status ParkFeatureIds(const SolveRun& run, Solve2d& s) {
  if (!s.streaming || run.distributed || s.checkpoint_path.empty() || s.id_file)
    return Status::Ok();
  s.id_file = std::make_unique<storage::FeatureIdFile>(storage::Env::Default(),
                                                       s.checkpoint_path + ".ids.bin");
  return s.id_file->Park(&s.problem.feature_ids);
}

// The streaming start (observations on disk): incremental initialization of
// a feature sample whose observations are bounded by the poses
// (partition/initialization/sampled_incremental_initialization.h); a store
// within that bound is sampled whole.
Status StartFromSampledFeatures(const SolveRun& run, Solve2d& s) {
  partition::SampledInitializationOptions sampled;
  sampled.incremental.max_observations_per_chunk = run.options.chunk_observations;
  sampled.budget_observations = run.options.sample_observations;
  sampled.max_observations = s.sample_observations;
  partition::SampledInitializationSummary summary;
  GS_RETURN_IF_ERROR(partition::InitializeFromSampledFeatures(
      sampled, InitializerOptions(s.solver), *s.chunks, s.num_observations, &s.problem, &summary));
  if (summary.capped)
    GS_LOG(WARNING, "sampled incremental initialization: sample budget capped at %lld "
           "observations by --memory-limit (what one chunk in flight leaves at %lld B each)",
           static_cast<long long>(summary.budget_observations),
           static_cast<long long>(kBytesPerObservationInMemory));
  GS_LOG(INFO, "sampled incremental initialization: %lld of %lld observations (rate %.4g, %lld "
         "features), %zu stages (%lld redone), sample solve %d iterations chi2 %.6g -> %.6g, "
         "%.1f s", static_cast<long long>(summary.sampled_observations),
         static_cast<long long>(s.num_observations), summary.rate,
         static_cast<long long>(summary.sampled_features), summary.incremental.stages.size(),
         static_cast<long long>(summary.incremental.redone_stages), summary.sub_solve_iterations,
         summary.sub_solve_initial_chi2, summary.sub_solve_final_chi2, summary.seconds);
  s.sampled_report = {{"budget_observations", summary.budget_observations},
                      {"capped_by_memory_limit", summary.capped},
                      {"rate", summary.rate},
                      {"sampled_features", summary.sampled_features},
                      {"sampled_observations", summary.sampled_observations},
                      {"stages", static_cast<int64_t>(summary.incremental.stages.size())},
                      {"redone_stages", summary.incremental.redone_stages},
                      {"broken_odometry_redos", summary.incremental.broken_odometry_redos},
                      {"broken_odometry_stretches", summary.incremental.broken_odometry_stretches},
                      {"broken_odometry_repairs", summary.incremental.broken_odometry_repairs},
                      {"sample_solve_iterations", summary.sub_solve_iterations},
                      {"sample_solve_final_chi2", summary.sub_solve_final_chi2},
                      {"seconds", summary.seconds}};
  return Status::Ok();
}

// The initializers that improve the Table 1 guess: incremental (the default's
// restart: stages re-solving a bounded window of recent poses, linear in
// poses), progressive (growing prefixes, each solved briefly), for a
// streaming solve the sampled incremental start, and for --initialization
// pose-graph the pose-graph initializer.
Status ImproveGuess(const SolveRun& run, Solve2d& s) {
  const SolveClock::time_point progressive_start = SolveClock::now();
  const double initialization_cpu_start = ProcessCpuSeconds();
  const Initialization init = run.request.initialization;
  const bool in_memory = !s.resuming && !s.streaming && run.root;
  partition::ProgressiveInitializationOptions progressive;
  progressive.enabled = init == Initialization::kProgressive && in_memory;
  progressive.max_observations_per_chunk = run.options.chunk_observations;
  progressive.max_new_poses = run.options.progressive_max_new_poses;
  partition::ProgressiveSummary progressive_summary;
  GS_RETURN_IF_ERROR(partition::InitializeProgressively(progressive, InitializerOptions(s.solver),
                                                       &s.problem, &progressive_summary));
  partition::IncrementalInitializationOptions incremental;
  incremental.enabled = (init == Initialization::kIncremental ||
                         (init == Initialization::kAuto && !s.probe_solved)) &&
                        in_memory;
  incremental.max_observations_per_chunk = run.options.chunk_observations;
  GS_RETURN_IF_ERROR(partition::InitializeIncrementally(incremental, InitializerOptions(s.solver),
                                                        &s.problem, &s.incremental_summary));
  const bool streaming_start =
      s.streaming && (init == Initialization::kProgressive || init == Initialization::kAuto ||
                      init == Initialization::kIncremental);
  if (!s.resuming && run.root && init == Initialization::kPoseGraph)
    GS_RETURN_IF_ERROR(StartFromPoseGraph(s, &s.problem));
  else if (!s.resuming && run.root && streaming_start) {
    GS_RETURN_IF_ERROR(ParkFeatureIds(run, s));
    GS_RETURN_IF_ERROR(StartFromSampledFeatures(run, s));
  }
  s.progressive_seconds = SecondsSince(progressive_start);
  s.initialization_cpu_seconds = ProcessCpuSeconds() - initialization_cpu_start;
  return Status::Ok();
}

// Before the checkpoint writer is attached (not under mpirun: every rank
// would use the same scratch files): streaming mode keeps no per-feature
// array of candidates (a scratch file beside the checkpoint,
// storage/candidate_file.h) and parks the feature ids there while it solves,
// if the start has not already (8 B per feature, the passes' peak included;
// only the outputs read them, storage/feature_id_file.h); the checkpoint's
// feature estimates go to a binary file, not JSON arrays.
Status PrepareCheckpoints(const SolveRun& run, Solve2d& s) {
  if (!s.streaming || run.distributed) return Status::Ok();
  s.candidate_file = std::make_unique<storage::CandidateFile>(
      storage::Env::Default(), s.checkpoint_path + ".candidates.bin");
  s.solver.candidate_store = s.candidate_file.get();
  return ParkFeatureIds(run, s);
}

Status WriteCheckpoint(const Solve2d& s, const std::string& input,
                       const core::SolverCheckpoint& checkpoint) {
  if (s.streaming)
    return storage::WriteSolverCheckpointWithFeatureFile(storage::Env::Default(),
                                                         s.checkpoint_path, input, checkpoint);
  return storage::WriteSolverCheckpoint(storage::Env::Default(), s.checkpoint_path, input,
                                        checkpoint);
}

// Unknown correspondence (docs/association.md): merges, then the final
// solve; a chunk store gets the associated problem (tools/association_store.h).
Status Associate(const SolveRun& run, Solve2d& s) {
  s.association.chi = run.options.chi;
  s.association.search_radius = run.options.association_radius;
  s.association.chunk_observations = run.options.chunk_observations;
  s.association.incremental.enabled =
      run.options.association != "batch" || run.options.associate_incremental;
  GS_RETURN_IF_ERROR(partition::AssociateAndSolve(s.association, s.solver, &s.problem,
                                                  &s.association_summary));
  s.summary = s.association_summary.final_solve;
  if (!s.store) return Status::Ok();
  return RewriteAssociatedChunkStore(storage::Env::Default(), s.store_path, s.problem,
                                     run.options.chunk_observations, s.store->source(),
                                     s.store->input(), &s.lock);
}

Status Optimize(const SolveRun& run, Solve2d& s) {
  const double optimize_cpu_start = ProcessCpuSeconds();
  if (run.options.associate) {
    GS_RETURN_IF_ERROR(Associate(run, s));
  } else if (run.distributed) {
    GS_RETURN_IF_ERROR(run.distributed->Solve(s.solver, *s.store, &s.problem, &s.summary,
                                              &s.distributed_report));
  } else if (!s.probe_solved) {
    const Status status = core::SolveGraphSlam(s.solver, *s.chunks, &s.problem, &s.summary);
    // A numerical failure names the input it happened on; nothing is
    // written (exit 5, not 4: tools/exit_codes.h).
    if (!status.ok())
      return status.IsNumerical() ? status.WithContext(run.options.input + ": solve") : status;
  }
  // A kept probe was the optimization.
  s.optimize_cpu_seconds =
      s.probe_solved ? s.probe_cpu_seconds : ProcessCpuSeconds() - optimize_cpu_start;
  s.display->Finish();
  if (s.id_file) GS_RETURN_IF_ERROR(s.id_file->Restore(&s.problem.feature_ids));
  return Status::Ok();
}

// The report's 2-D keys (tools/pipeline/solve_path.h: SolveReport gives the
// shared ones).
void AddReport(const SolveRun& run, const Solve2d& s, nlohmann::json* report_out) {
  const SolveCommandOptions& options = run.options;
  nlohmann::json& report = *report_out;
  // -o renumbers features past the largest pose id when the ids collide
  // (storage/g2o_writer.h): the written id is the feature id plus this.
  if (!options.output_g2o.empty()) {
    StatusOr<int64_t> offset = storage::G2oFeatureIdOffset(s.problem);
    if (offset.ok()) report["g2o_feature_id_offset"] = *offset;
  }
  // What --initialization auto did: the solve from odometry (the final one
  // when it converged), or incremental initialization after it.
  report["initialization_used"] = options.initialization != "auto" ? options.initialization
                                  : s.streaming                    ? "sampled-incremental"
                                  : s.probe_solved                 ? "odometry"
                                                                   : "incremental";
  if (s.incremental_summary.ran) {
    int64_t most_solved = 0;
    for (const partition::IncrementalStageSummary& stage : s.incremental_summary.stages)
      most_solved = std::max(most_solved, stage.solved_poses);
    report["incremental_initialization"] = {
        {"stages", static_cast<int64_t>(s.incremental_summary.stages.size())},
        {"most_poses_solved_in_a_stage", most_solved},
        {"redone_stages", s.incremental_summary.redone_stages},
        {"broken_odometry_redos", s.incremental_summary.broken_odometry_redos},
        {"broken_odometry_stretches", s.incremental_summary.broken_odometry_stretches},
        {"broken_odometry_repairs", s.incremental_summary.broken_odometry_repairs},
        {"seconds", s.incremental_summary.seconds}};
  }
  if (!s.sampled_report.is_null()) report["sampled_incremental_initialization"] = s.sampled_report;
  if (s.probe) {
    report["odometry_attempt"] = s.probe_report;
    report["stage_seconds"]["odometry_attempt"] = s.probe_seconds;
  }
  if (s.store) report["store"] = s.store_path;
  if (run.distributed) report["distributed"] = s.distributed_report["distributed"];
  if (s.format_name == std::string_view("mrclam"))
    report["mrclam"] = {
        {"robot_measurements_dropped", s.mrclam_stats.robot_measurements_dropped},
        {"out_of_time_range_dropped", s.mrclam_stats.out_of_time_range_dropped},
        {"unknown_barcodes_skipped", s.mrclam_stats.unknown_barcodes_skipped},
        {"unknown_barcode_lines", s.mrclam_stats.unknown_barcode_lines}};
  if (options.associate)
    report["association"] = BuildAssociationReport(s.association, s.association_summary, 200);
}

void PrintAssociation(std::FILE* out, const partition::AssociationSummary& a) {
  std::fprintf(out, "  association        %lld -> %lld features, %lld merges (%lld undone), "
               "%zu rounds, %.3f s\n",
               static_cast<long long>(a.initial_features), static_cast<long long>(a.final_features),
               static_cast<long long>(a.merges), static_cast<long long>(a.undone), a.rounds.size(),
               a.seconds);
  const partition::IncrementalAssociationSummary& inc = a.incremental;
  if (!inc.ran) return;
  std::fprintf(out, "  incremental pass   %lld stages, %lld features found, %lld provisional "
               "joined at the end, %lld dropped as clutter (%lld observations); solve %.2f s, "
               "covariances %.2f s, assignment %.2f s\n",
               static_cast<long long>(inc.stages), static_cast<long long>(inc.features),
               static_cast<long long>(inc.provisional_rescued),
               static_cast<long long>(inc.provisional_dropped),
               static_cast<long long>(inc.clutter_observations), inc.solve_seconds,
               inc.covariance_seconds, inc.assignment_seconds);
}

// The 2-D steps of tools/pipeline/solve_path.h.
struct Hooks2d {
  using Space = core::Space2d;
  using State = Solve2d;
  static constexpr int kDimension = 2;

  static Status ReadInput(const SolveRun& run, const DetectedInput* file, Solve2d& s) {
    return tools::ReadInput(run, file, s);
  }
  static Status InitializeGuess(const SolveRun& run, Solve2d& s) {
    return tools::InitializeGuess(run, s);
  }
  static Status ConfigureChunks(const SolveRun& run, Solve2d& s) {
    return tools::ConfigureChunks(run, s);
  }
  // A store is checkpointed by default (STORE/checkpoint.json), unless
  // --associate rewrites it.
  static std::string DefaultCheckpointPath(const SolveRun& run, const Solve2d& s) {
    return s.store && !run.options.associate ? s.store_path + "/checkpoint.json" : "";
  }
  static StatusOr<core::SolverCheckpoint> ReadCheckpoint(const std::string& path,
                                                        const std::string& input) {
    return storage::ReadSolverCheckpoint(path, input);
  }
  static Status ImproveGuess(const SolveRun& run, Solve2d& s) {
    GS_RETURN_IF_ERROR(TryOdometry(run, s));
    return tools::ImproveGuess(run, s);
  }
  static Status PrepareCheckpoints(const SolveRun& run, Solve2d& s) {
    return tools::PrepareCheckpoints(run, s);
  }
  static void SetResume(Solve2d& s) { s.solver.resume_from = &s.resume_state; }
  static void SetCheckpointWriter(Solve2d& s, CheckpointWriter<Space> writer) {
    s.solver.checkpoint_callback = std::move(writer);
  }
  static Status WriteCheckpoint(const Solve2d& s, const std::string& input,
                                const core::SolverCheckpoint& checkpoint) {
    return tools::WriteCheckpoint(s, input, checkpoint);
  }
  static Status Optimize(const SolveRun& run, Solve2d& s) { return tools::Optimize(run, s); }
  static Status WriteGraph(const Solve2d& s, const std::string& path) {
    return storage::WriteG2o(s.problem, path);
  }
  static Status WriteTrajectory(const Solve2d& s, const std::string& path) {
    return storage::WriteTum(s.problem, path);
  }
  static Status WriteFeatures(const Solve2d& s, const std::string& path) {
    return storage::WriteFeaturesCsv(s.problem, path, &s.summary.excluded);
  }
  static void AddReport(const SolveRun& run, const Solve2d& s, nlohmann::json* report) {
    tools::AddReport(run, s, report);
  }
  static void PrintCounts(std::FILE*, const Solve2d&) {}
  static void PrintDetails(std::FILE* out, const SolveRun& run, const Solve2d& s) {
    if (run.options.associate) PrintAssociation(out, s.association_summary);
  }
};

}  // namespace

int RunSolve2d(SolveRun& run, const DetectedInput* file) {
  return RunSolvePath<Hooks2d>(run, file);
}

}  // namespace graphslam::tools

#include "tools/solve_command.h"

#include <tbb/global_control.h>
#include <tbb/info.h>

#include <chrono>
#include <filesystem>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <nlohmann/json.hpp>
#include <string_view>
#include <vector>

#include "core/graphslam_solver.h"
#include "core/initialization.h"
#include "core/logging.h"
#include "core/unidentified_features.h"
#include "partition/association_driver.h"
#include "partition/gps_segment_alignment.h"
#include "partition/in_memory_chunk_source.h"
#include "partition/pose_graph_initialization.h"
#include "partition/progressive_initialization.h"
#include "storage/atomic_file.h"
#include "storage/solver_checkpoint.h"
#include "storage/candidate_file.h"
#include "storage/feature_id_file.h"
#include "storage/chunk_store.h"
#include "storage/dimension_detection.h"
#include "storage/directory_lock.h"
#include "storage/store_directory.h"
#include "storage/features_csv_writer.h"
#include "storage/format_detection.h"
#include "storage/g2o_writer.h"
#include "storage/tum_writer.h"
#include "tools/association_report.h"
#include "tools/association_store.h"
#include "tools/distributed_solve_command.h"
#include "tools/exit_codes.h"
#include "tools/memory_size.h"
#include "tools/option_checks.h"
#include "tools/output_paths.h"
#include "tools/out_of_core_solve.h"
#include "tools/progress_display.h"
#include "tools/resource_usage.h"
#include "tools/solve_3d_command.h"
#include "tools/solve_report.h"

namespace graphslam::tools {
namespace {

using Clock = std::chrono::steady_clock;

// --initialization auto abandons the odometry start at a step with rho below
// this: the classic trust-region bound of a poor quadratic model. Measured from
// odometry (docs/benchmarks.md): the lowest rho of a step that meant to matter
// is 0.82 on intel, 0.41 on M3500, 0.94 on city10000; Victoria Park has 0.22
// at step 6 and goes on to a local minimum.
constexpr double kAutoAbandonRho = 0.25;

double Seconds(Clock::time_point since) {
  return std::chrono::duration<double>(Clock::now() - since).count();
}

Status ValidateOptions(const SolveCommandOptions& options) {
  if (options.input.empty()) return Status::InvalidArgument("no INPUT given");
  if (options.max_iterations < 0)
    return Status::InvalidArgument("--max-iterations must be >= 0, got " +
                                   std::to_string(options.max_iterations));
  if (options.threads < 0)
    return Status::InvalidArgument("--threads must be >= 0, got " + std::to_string(options.threads));
  if (options.max_eliminated_observations < 0)
    return Status::InvalidArgument("--max-eliminated-observations must be >= 0");
  if (options.initialization != "auto" && options.initialization != "progressive" &&
      options.initialization != "odometry" && options.initialization != "pose-graph" &&
      options.initialization != "as-given")
    return Status::InvalidArgument(
        "--initialization must be auto, progressive, odometry, pose-graph or as-given, got '" +
        options.initialization + "'");
  if (options.resume && options.checkpoint.empty() && !storage::IsChunkStore(options.input) &&
      options.workdir.empty())
    return Status::InvalidArgument("--resume needs --checkpoint FILE (or a chunk store as input)");
  if (options.chunk_observations <= 0)
    return Status::InvalidArgument("--chunk-observations must be > 0");
  if (options.associate && (options.resume || !options.checkpoint.empty()))
    return Status::InvalidArgument("--associate cannot be combined with --checkpoint/--resume");
  if (options.associate && !options.workdir.empty())
    return Status::InvalidArgument(
        "--associate cannot be combined with --workdir (merges rewrite the in-memory chunks "
        "only)");
  return Status::Ok();
}

nlohmann::json BuildReport(const SolveCommandOptions& options, const core::Problem2d& problem,
                           const core::SolverSummary& summary, const char* format_name,
                           double read_seconds, double initialize_seconds,
                           double progressive_seconds, double total_seconds,
                           int64_t num_observations) {
  nlohmann::json report = SolverReport(options, summary, format_name, total_seconds);
  report["poses"] = problem.num_poses();
  report["features"] = problem.num_features();
  report["observations"] = num_observations;
  report["relative_pose_constraints"] = static_cast<int64_t>(problem.relative_poses.size());
  report["motion_constraints"] = static_cast<int64_t>(problem.motions.size());
  report["gps_constraints"] = static_cast<int64_t>(problem.gps.size());
  report["robot_sighting_constraints"] = static_cast<int64_t>(problem.pose_range_bearings.size());
  // Degrees of freedom: chi2 / (residual_dimension - unknowns) should be near 1
  // when the noise is what the model says.
  const int64_t residual_dimension =
      3 * static_cast<int64_t>(problem.relative_poses.size() + problem.motions.size()) +
      2 * static_cast<int64_t>(problem.gps.size() + problem.pose_range_bearings.size()) +
      2 * summary.observations_used;
  report["residual_dimension"] = residual_dimension;
  report["unknowns"] =
      3 * summary.unknown_poses + 2 * (summary.eliminated_features + summary.kept_features);
  report["stage_seconds"] = {{"read", read_seconds},
                             {"initialize", initialize_seconds},
                             {"progressive_initialization", progressive_seconds},
                             {"optimize", summary.seconds}};
  return report;
}

const char* FormatName(storage::InputFormat format) {
  switch (format) {
    case storage::InputFormat::kG2o: return "g2o";
    case storage::InputFormat::kIsam: return "isam";
    case storage::InputFormat::kMrclam: return "mrclam";
    case storage::InputFormat::kNative: return "native";
    case storage::InputFormat::kToro: return "toro";
  }
  return "unknown";
}

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
// the input must give every pose and every observed feature a guess (a g2o file with all its VERTEX lines, e.g. one written by
// `graphslam solve -o`), since nothing will be filled in.
Status CheckEveryGuessGiven(const core::Problem2d& problem) {
  for (int32_t i = 0; i < problem.num_poses(); ++i) {
    if (problem.pose_initialized[i] != 0) continue;
    // Built by append: GCC 12 gives a false -Wrestrict on `":" + std::string` at -O3.
    std::string where = problem.source;
    if (problem.pose_lines[i] > 0) {
      where.push_back(':');
      where.append(std::to_string(problem.pose_lines[i]));
    }
    return Status::InvalidArgument(
        where + ": pose " + std::to_string(problem.pose_ids[i]) +
        " has no initial guess in the input; --initialization as-given needs a guess (VERTEX "
        "line) for every pose and observed feature, expected e.g. a graph written by "
        "`graphslam solve -o`");
  }
  std::vector<uint8_t> observed(problem.features.size(), 0);
  for (const core::Observation& o : problem.observations) observed[o.feature] = 1;
  for (int32_t j = 0; j < problem.num_features(); ++j) {
    if (observed[j] == 0 || problem.feature_initialized[j] != 0) continue;
    return Status::InvalidArgument(
        problem.source + ": feature " + std::to_string(problem.feature_ids[j]) +
        " has no initial guess in the input; --initialization as-given needs a guess (VERTEX "
        "line) for every pose and observed feature, expected e.g. a graph written by "
        "`graphslam solve -o`");
  }
  return Status::Ok();
}

}  // namespace

void AddSolveCommand(CLI::App* app, SolveCommandOptions* options, int* exit_code) {
  CLI::App* solve = app->add_subcommand(
      "solve",
      "Optimize one input (g2o, iSAM, TORO .graph, MRCLAM folder, native log, chunk store) and "
      "write the results");
  solve->add_option("input", options->input, "input file or MRCLAM dataset folder")->required();
  solve->add_option("-o,--output", options->output_g2o, "optimized graph (.g2o)");
  solve->add_option("--format", options->format, "input format: auto, g2o, isam, mrclam, native, toro")
      ->capture_default_str();
  solve->add_option("--solver", options->solver, "reduced system solver: auto, pcg, cholmod")
      ->capture_default_str();
  solve->add_option("--preconditioner", options->preconditioner,
                    "PCG preconditioner: block-jacobi, incomplete-cholesky, subgraph")
      ->capture_default_str();
  solve->add_option("--pcg-eta-min", options->pcg_eta_min,
                    "PCG: the tightest relative residual (the forcing sequence's floor, and the "
                    "tolerance of exact solves), in (0, --pcg-eta-max]")
      ->check(Real(0.0, 1.0, Bounds::kOpen))
      ->capture_default_str();
  solve->add_option("--pcg-eta-max", options->pcg_eta_max,
                    "PCG: the loosest relative residual of the forcing sequence, in (0, 1)")
      ->check(Real(1e-10, 1.0, Bounds::kOpenUpper))
      ->capture_default_str();
  solve->add_option("--pcg-deflation", options->pcg_deflation,
                    "PCG: deflate the trajectory's smooth error modes, in aggregates of this many "
                    "consecutive poses (constant and linear modes each); 0: off")
      ->check(Integer(0, std::numeric_limits<int>::max()))
      ->capture_default_str();
  solve->add_option("--pcg-truncation", options->pcg_truncation,
                    "PCG: stop a solve once the chi2 decrease it still misses is estimated below "
                    "this x --function-tolerance x chi2, in [0, 1); 0: off")
      ->check(Real(0.0, 1.0, Bounds::kOpenUpper))
      ->capture_default_str();
  solve->add_option("--max-iterations", options->max_iterations, "Levenberg-Marquardt iterations")
      ->check(Integer(0, std::numeric_limits<int>::max()))
      ->capture_default_str();
  solve->add_option("--function-tolerance", options->function_tolerance,
                    "stop when the relative chi2 decrease of a step is below this")
      ->check(Real(0.0, 1.0, Bounds::kOpenUpper))
      ->capture_default_str();
  solve->add_option("--initial-trust-region", options->initial_trust_region_radius,
                    "initial trust region radius (1 / initial damping; default: 1e8 with "
                    "CHOLMOD, 1e4 with PCG)")
      ->check(Real(0.0, core::SolverOptions().max_trust_region_radius, Bounds::kOpenLower));
  solve->add_option("--threads", options->threads, "worker threads (0: all cores)")
      ->check(Integer(0, 65536))
      ->capture_default_str();
  solve->add_option("--report", options->report, "run report (.json)");
  solve->add_option("--tum", options->tum, "optimized trajectory (TUM format)");
  solve->add_option("--features-csv", options->features_csv, "optimized features (.csv)");
  solve->add_option("--robot", options->robot, "MRCLAM robot number")
      ->check(Integer(1, 5))
      ->capture_default_str();
  solve->add_option("--chunk-observations", options->chunk_observations,
                    "observations per chunk (feature-complete)")
      ->check(Integer(1))
      ->capture_default_str();
  solve->add_option("--max-eliminated-observations", options->max_eliminated_observations,
                    "features with more observations stay unknowns instead of being eliminated")
      ->check(Integer(0))
      ->capture_default_str();
  solve->add_option("--robust-kernel", options->robust_kernel,
                    "[TYPE=]K, K one of none, huber[:c], cauchy[:c]; TYPE one of observation "
                    "(the default), odometry, motion, gps; repeatable")
      ->join(' ')
      ->capture_default_str();
  solve->add_option("--initialization", options->initialization,
                    "initial guess: auto (odometry, then progressive if the first steps show "
                    "it is outside the optimum's basin), "
                    "progressive (solve growing prefixes of the trajectory), "
                    "odometry (the paper's Table 1 only), pose-graph (Table 1, then the pose-only "
                    "problem solved and the features re-placed) or as-given (the input's guess "
                    "unchanged; every vertex must have one)")
      ->capture_default_str();
  solve->add_option("--progressive-max-new-poses", options->progressive_max_new_poses,
                    "at most this many poses join per progressive stage")
      ->check(Integer(0))
      ->capture_default_str();
  solve->add_option("--checkpoint", options->checkpoint,
                    "solver checkpoint file, replaced atomically after every iteration "
                    "(default for a chunk store: STORE/checkpoint.json)");
  solve->add_flag("--resume", options->resume,
                  "continue from the checkpoint, if one exists (after a crash or kill -9)");
  solve->add_option("--workdir", options->workdir,
                    "ingest a FILE input into this chunk store directory and solve from it "
                    "(kept afterwards; without it a FILE is solved in memory)");
  solve->add_option("--memory-limit", options->memory_limit,
                    "memory budget (e.g. 2G): bounds the chunks in flight and the ingest buffer");
  solve->add_flag("--two-pass", options->two_pass,
                  "two passes over the observation chunks every iteration instead of one "
                  "fused pass (for measurements; same results)");
  solve->add_option("--streaming-poses", options->streaming_poses,
                    "stores with more poses skip progressive initialization (streaming mode)")
      ->check(Integer(0))
      ->capture_default_str();
  solve->add_option("--streaming-observations", options->streaming_observations,
                    "stores with more observations are solved without loading them (streaming mode)")
      ->check(Integer(0))
      ->capture_default_str();
  solve->add_flag("--associate", options->associate,
                  "unknown correspondence: merge features by the correspondence test "
                  "(paper Tables 9-10; docs/association.md)");
  solve->add_option("--chi", options->chi,
                    "with --associate: merge when the correspondence probability exceeds this")
      ->check(Real(0.0, 1.0))
      ->capture_default_str();
  solve->add_option("--association-radius", options->association_radius,
                    "with --associate: test feature pairs closer than this [m]")
      ->check(PositiveReal())
      ->capture_default_str();
  solve->add_flag("--ignore-barcodes", options->ignore_barcodes,
                  "MRCLAM: drop the landmark identities (use with --associate)");
  solve->add_option("--petsc-options", options->petsc_options,
                    "under mpirun: PETSc options for the reduced system's solve, e.g. "
                    "\"-ksp_type cg -pc_type gamg\" (PETSC_OPTIONS works too; docs/distributed.md)");
  solve->add_flag("-q,--quiet", options->quiet, "no progress or summary on the terminal");
  solve->add_flag("-v,--verbose", options->verbosity, "more log detail (repeatable)");
  solve->callback([options, exit_code]() { *exit_code = RunSolveCommand(*options); });
}

bool WritesToStandardOutput(const SolveCommandOptions& options) {
  for (const std::string* path :
       {&options.output_g2o, &options.tum, &options.features_csv, &options.report})
    if (*path == storage::kStandardOutput) return true;
  return false;
}

int RunSolveCommand(const SolveCommandOptions& options) {
  const Clock::time_point start = Clock::now();
  SetLogVerbosity(options.verbosity);
  SetQuietLogging(options.quiet);
  // Under mpirun (see below) a failure of one rank ends them all: the
  // others may be waiting for it in a collective call.
  std::unique_ptr<DistributedSolveRun> distributed;
  auto fail = [&distributed](const Status& status) {
    std::fprintf(stderr, "graphslam solve: %s\n", status.ToString().c_str());
    if (distributed != nullptr && distributed->size() > 1) distributed->Abort(ExitCodeFor(status));
    return ExitCodeFor(status);
  };
  if (Status status = ValidateOptions(options); !status.ok()) {
    std::fprintf(stderr, "graphslam solve: %s\n", status.ToString().c_str());
    return kExitUsage;
  }
  // Every output must be writable where it goes before hours of solving.
  if (Status status = CheckOutputPaths({{"-o", options.output_g2o},
                                        {"--tum", options.tum},
                                        {"--features-csv", options.features_csv},
                                        {"--report", options.report},
                                        {"--checkpoint", options.checkpoint},
                                        {"--workdir", options.workdir, /*folder=*/true}});
      !status.ok())
    return fail(status);
  StatusOr<core::LinearSolverType> solver_type = core::ParseLinearSolverType(options.solver);
  if (!solver_type.ok()) {
    std::fprintf(stderr, "graphslam solve: --solver: %s\n", solver_type.status().ToString().c_str());
    return kExitUsage;
  }

  StatusOr<core::PreconditionerType> preconditioner =
      core::ParsePreconditionerType(options.preconditioner);
  if (!preconditioner.ok()) {
    std::fprintf(stderr, "graphslam solve: --preconditioner: %s\n",
                 preconditioner.status().ToString().c_str());
    return kExitUsage;
  }
  // The exact-solve tolerance (1e-10) is the tightest forcing term.
  if (!(options.pcg_eta_min > 0.0) || !(options.pcg_eta_min <= options.pcg_eta_max)) {
    std::fprintf(stderr, "graphslam solve: --pcg-eta-min must be in (0, --pcg-eta-max = %g], "
                 "got %g\n", options.pcg_eta_max, options.pcg_eta_min);
    return kExitUsage;
  }
  if (options.pcg_deflation < 0 || options.pcg_deflation == 1) {
    std::fprintf(stderr, "graphslam solve: --pcg-deflation must be 0 (off) or >= 2 poses, got %d\n",
                 options.pcg_deflation);
    return kExitUsage;
  }
  if (!(options.pcg_truncation >= 0.0) || !(options.pcg_truncation < 1.0)) {
    std::fprintf(stderr, "graphslam solve: --pcg-truncation must be in [0, 1), got %g\n",
                 options.pcg_truncation);
    return kExitUsage;
  }
  if (!(options.pcg_eta_max >= core::SolverOptions().pcg_relative_tolerance) ||
      !(options.pcg_eta_max < 1.0)) {
    std::fprintf(stderr, "graphslam solve: --pcg-eta-max must be in [1e-10, 1), got %g\n",
                 options.pcg_eta_max);
    return kExitUsage;
  }
  // Under mpirun a chunk store is solved over the launched processes
  // (docs/distributed.md); rank 0 initializes (its start is broadcast),
  // reports and writes the outputs.
  if (const int launched = LaunchedProcesses();
      launched > 0 && storage::IsChunkStore(options.input)) {
    if (options.associate) {
      std::fprintf(stderr, "graphslam solve: under mpirun, --associate is not supported yet "
                   "(docs/distributed.md)\n");
      return kExitUsage;
    }
    StatusOr<std::unique_ptr<DistributedSolveRun>> started =
        DistributedSolveRun::Start(options.petsc_options);
    if (started.ok()) {
      distributed = std::move(started).value();
    } else if (launched > 1) {
      return fail(started.status());
    }  // else one launched process without MPI support: the usual solve
  } else if (launched > 1) {
    return fail(Status::NotSupported(
        "under mpirun with " + std::to_string(launched) + " processes the input must be a "
        "chunk store (graphslam ingest INPUT -o STORE/), got " + options.input));
  }
  const bool root = distributed == nullptr || distributed->rank() == 0;
  const bool quiet = options.quiet || !root;
  if (!root) SetQuietLogging(true);

  core::RobustKernel observation_kernel;
  core::PoseFactorKernels pose_kernels;
  if (Status kernels = core::ApplyRobustKernelOption(options.robust_kernel, &observation_kernel,
                                                     &pose_kernels);
      !kernels.ok()) {
    std::fprintf(stderr, "graphslam solve: --robust-kernel: %s\n", kernels.ToString().c_str());
    return kExitUsage;
  }

  // Read. A chunk store (graphslam ingest) needs no format detection: the
  // problem is its pose-only native log and the solve streams its chunks from
  // disk. Its observations are also loaded back into the problem, for
  // progressive initialization (which needs them) and the report.
  std::unique_ptr<storage::DiskChunkSource> store;
  core::Problem2d problem;
  const char* format_name = "chunk-store";
  storage::MrclamReadStats mrclam_stats;  // an MRCLAM input's skipped records
  int64_t memory_limit = 0;
  if (!options.memory_limit.empty()) {
    StatusOr<int64_t> parsed = ParseMemorySize(options.memory_limit);
    if (!parsed.ok()) {
      std::fprintf(stderr, "graphslam solve: --memory-limit: %s\n",
                   parsed.status().ToString().c_str());
      return kExitUsage;
    }
    memory_limit = *parsed;
  }
  // Locks (storage/directory_lock.h), held to the end: the workdir, or a
  // store this solve writes into (STORE/checkpoint.json, an --associate
  // rewrite), exclusively; a store it only reads, shared. A second writer
  // fails here, naming the holder's pid.
  storage::DirectoryLock lock;
  const bool through_workdir = !options.workdir.empty() && !storage::IsChunkStore(options.input);
  if (through_workdir) {
    // A folder that is not ours is refused before anything is written.
    StatusOr<storage::DirectoryLock> locked =
        storage::OpenStoreForWriting(storage::Env::Default(), options.workdir);
    if (!locked.ok()) return fail(locked.status());
    lock = std::move(locked).value();
  } else if (storage::IsChunkStore(options.input)) {
    // Under mpirun rank 0 alone writes (STORE/checkpoint.json) and holds
    // the lock for the job; the other ranks only read and take none (a
    // shared lock of theirs would block rank 0's exclusive one).
    const bool writes = options.checkpoint.empty() || options.associate;
    if (root) {
      StatusOr<storage::DirectoryLock> locked = storage::DirectoryLock::Acquire(
          options.input, writes ? storage::DirectoryLock::Mode::kExclusive
                                : storage::DirectoryLock::Mode::kShared);
      if (!locked.ok()) return fail(locked.status());
      lock = std::move(locked).value();
    }
    // Under the exclusive lock a temporary file in a store of ours is one a
    // killed writer left (a checkpoint's): nobody will rename it.
    if (root && writes && storage::CheckStoreDirectory(options.input).ok()) {
      if (Status status = storage::RemoveStaleTemporaries(storage::Env::Default(), options.input,
                                                          /*recursive=*/true);
          !status.ok())
        return fail(status);
    }
  }
  // --workdir: a FILE goes through a chunk store in DIR (bounded-memory ingest).
  std::string store_path = options.input;
  if (through_workdir) {
    // --resume reuses the store its checkpoint was made on, if still current
    // (the same input: size and CRC32C, not the mtime).
    if (options.resume && WorkdirStoreIsCurrent(options.input, options.workdir)) {
      if (Status status = storage::RemoveStaleTemporaries(storage::Env::Default(),
                                                          options.workdir, /*recursive=*/true);
          !status.ok())
        return fail(status);
    } else {
      if (Status status = IngestIntoWorkdir(options.input, options.format, options.robot,
                                            options.workdir, options.chunk_observations,
                                            memory_limit, options.resume);
          !status.ok())
        return fail(status);
    }
    store_path = options.workdir;
  }
  bool streaming = false;  // observations stay on disk; the ingest's guess starts
  int64_t num_observations = 0;
  if (storage::IsChunkStore(store_path)) {
    StatusOr<std::unique_ptr<storage::DiskChunkSource>> opened =
        storage::DiskChunkSource::Open(store_path);
    if (!opened.ok()) return fail(opened.status());
    store = std::move(opened).value();
    StatusOr<core::Problem2d> read = storage::ReadChunkStoreProblem(store_path);
    if (!read.ok()) return fail(read.status());
    problem = std::move(read).value();
    num_observations = store->total_observations();
    // --associate merges in memory (then rewrites the store): never streams.
    streaming = !options.associate && (problem.num_poses() > options.streaming_poses ||
                                       num_observations > options.streaming_observations);
    if (streaming) {
      GS_LOG(INFO, "streaming mode: %d poses, %lld observations stay on disk; initial guess "
             "from the ingest (Table 1), no progressive initialization",
             problem.num_poses(), static_cast<long long>(num_observations));
    } else if (!root) {
      // Rank 0 loads them for the initialization; its start is broadcast.
    } else if (Status status = LoadObservations(*store, &problem); !status.ok()) {
      return fail(status);
    }
  } else {
    storage::InputFormat format;
    if (options.format == "auto") {
      StatusOr<storage::InputFormat> detected = storage::DetectInputFormat(options.input);
      if (!detected.ok()) return fail(detected.status());
      format = *detected;
    } else {
      StatusOr<storage::InputFormat> parsed = storage::ParseInputFormat(options.format);
      if (!parsed.ok()) {
        std::fprintf(stderr, "graphslam solve: --format: %s\n", parsed.status().ToString().c_str());
        return kExitUsage;
      }
      format = *parsed;
    }
    // 3-D inputs (SE(3) poses) take the 3-D path (tools/solve_3d_command.h).
    StatusOr<bool> three_d = storage::IsThreeDimensional(options.input, format);
    if (!three_d.ok()) return fail(three_d.status());
    if (*three_d) return RunSolve3dCommand(options, format, *solver_type, *preconditioner);
    storage::MrclamOptions mrclam;
    mrclam.robot = options.robot;
    mrclam.ignore_barcodes = options.ignore_barcodes;
    StatusOr<core::Problem2d> read =
        storage::ReadProblem(options.input, format, mrclam, &mrclam_stats);
    if (!read.ok()) return fail(read.status());
    problem = std::move(read).value();
    const core::UnidentifiedObservations unidentified =
        core::CountUnidentifiedObservations(problem);
    if (unidentified.count > 0 && !options.associate) {
      return fail(Status::NotSupported(
          options.input + ":" + std::to_string(unidentified.first_line) + ": " +
          std::to_string(unidentified.count) +
          " observations have no feature id (unknown correspondence); expected ids, or "
          "--associate to find the correspondences"));
    }
    format_name = FormatName(format);
  }
  if (!streaming) num_observations = static_cast<int64_t>(problem.observations.size());
  const double read_seconds = Seconds(start);

  // Initialize (Table 1) and validate connectivity. --initialization as-given
  // only checks: the input's guess is the start, bit for bit.
  const Clock::time_point initialize_start = Clock::now();
  // (Streaming: the ingest initialized and checked with every observation.)
  if (!streaming && root && options.initialization == "as-given") {
    if (Status status = core::ValidateProblem(problem); !status.ok()) return fail(status);
    if (Status status = CheckEveryGuessGiven(problem); !status.ok()) return fail(status);
  } else if (!streaming && root) {
    if (Status status = core::InitializeProblem(&problem); !status.ok()) return fail(status);
  }
  const double initialize_seconds = Seconds(initialize_start);

  // Partition and solve.
  std::unique_ptr<tbb::global_control> threads;
  if (options.threads > 0) {
    threads = std::make_unique<tbb::global_control>(
        tbb::global_control::max_allowed_parallelism, static_cast<size_t>(options.threads));
  }
  partition::ChunkingOptions chunking;
  chunking.max_observations_per_chunk = options.chunk_observations;
  std::unique_ptr<partition::InMemoryChunkSource> in_memory;
  if (!store) in_memory = std::make_unique<partition::InMemoryChunkSource>(problem, chunking);
  const core::ChunkSource& chunks =
      store ? static_cast<const core::ChunkSource&>(*store) : *in_memory;

  ProgressDisplay display(!quiet);
  core::SolverOptions solver_options;
  solver_options.linear_solver = *solver_type;
  solver_options.preconditioner = *preconditioner;
  solver_options.pcg_eta_max = options.pcg_eta_max;
  solver_options.pcg_deflation_poses = options.pcg_deflation;
  solver_options.pcg_truncation = options.pcg_truncation;
  solver_options.pcg_relative_tolerance = options.pcg_eta_min;
  solver_options.max_iterations = options.max_iterations;
  solver_options.max_eliminated_observations = options.max_eliminated_observations;
  solver_options.observation_kernel = observation_kernel;
  solver_options.pose_kernels = pose_kernels;
  solver_options.function_tolerance = options.function_tolerance;
  solver_options.initial_trust_region_radius = options.initial_trust_region_radius;
  solver_options.fused_chunk_pass = !options.two_pass;
  solver_options.progress = display.AsCallback();
  solver_options.iteration_callback = display.AsIterationCallback();
  {
    StatusOr<int> in_flight = ChunksInFlightForMemoryLimit(
        memory_limit, problem.num_poses(), problem.num_features(), options.chunk_observations,
        solver_options.max_chunks_in_flight, streaming);
    if (!in_flight.ok()) return fail(in_flight.status());
    solver_options.max_chunks_in_flight = *in_flight;
  }
  // Checkpoints: one durable file, replaced atomically after every iteration;
  // --resume continues from it (bit-identical to an uninterrupted solve).
  std::string checkpoint_path = options.checkpoint;
  if (checkpoint_path.empty() && store && !options.associate)
    checkpoint_path = store_path + "/checkpoint.json";
  if (options.resume && checkpoint_path.empty()) {
    std::fprintf(stderr, "graphslam solve: --resume needs --checkpoint FILE (or a chunk store)\n");
    return kExitUsage;
  }
  core::SolverCheckpoint resume_state;
  // Under mpirun rank 0 reads it and broadcasts it (docs/distributed.md).
  const bool resuming = root && options.resume && std::filesystem::exists(checkpoint_path);
  if (resuming) {
    StatusOr<core::SolverCheckpoint> read_checkpoint =
        storage::ReadSolverCheckpoint(checkpoint_path, options.input);
    if (!read_checkpoint.ok()) return fail(read_checkpoint.status());
    resume_state = std::move(read_checkpoint).value();
    GS_LOG(INFO, "resuming from %s after iteration %d (chi2 %.9g)", checkpoint_path.c_str(),
           resume_state.iterations, resume_state.chi2);
  } else if (options.resume && root) {
    GS_LOG(WARNING, "no checkpoint at %s yet: starting from the beginning",
           checkpoint_path.c_str());
  }

  // --initialization auto: the full solve from the Table 1 guess, abandoned
  // at its first step whose model failed (rho < kAutoAbandonRho on a step
  // that meant to matter, core/levenberg_marquardt.h); kept if it converged,
  // else (abandoned, or stopped by --max-iterations) the restart. Most pose graphs
  // converge from their odometry in 5-30 well-modelled steps (intel, M3500,
  // city10000 reach their optima); a start outside the optimum's basin
  // (Victoria Park: rho 0.22 at step 6, then rejections, a local minimum at
  // chi2 34114) shows it within its first steps, and the solve restarts from
  // the Table 1 guess with progressive initialization, as
  // --initialization progressive does. Not with checkpoints (a probe's
  // checkpoint would resume the wrong solve), --associate, streaming or
  // under mpirun (a store's ranks start progressively, as one process does).
  core::SolverSummary summary;
  const bool probe = options.initialization == "auto" && !resuming && !streaming &&
                     checkpoint_path.empty() && !options.associate && !distributed &&
                     options.max_iterations > 0;
  bool probe_solved = false;
  // chi2 of the input's own estimate (Table 1 fills only what it lacks): the
  // probe's start. The solve's initial chi2 is after initialization.
  double input_chi2 = std::numeric_limits<double>::quiet_NaN();
  nlohmann::json probe_report;
  const Clock::time_point probe_start = Clock::now();
  const double probe_cpu_start = ProcessCpuSeconds();
  if (probe) {
    const std::vector<core::Pose2> guess_poses = problem.poses;
    const std::vector<core::Point2> guess_features = problem.features;
    core::SolverOptions probe_options = solver_options;
    probe_options.abandon_below_rho = kAutoAbandonRho;
    const Status status = core::SolveGraphSlam(probe_options, chunks, &problem, &summary);
    if (!status.ok() && !status.IsNumerical()) return fail(status);
    // Kept only when it converged: a probe stopped by --max-iterations
    // (never abandoned, never converged) is no answer either.
    probe_solved = status.ok() && summary.converged;
    input_chi2 = summary.initial_chi2;
    probe_report = {{"iterations", summary.iterations},
                    {"final_chi2", summary.final_chi2},
                    {"termination", status.ok() ? summary.termination : status.ToString()},
                    {"seconds", Seconds(probe_start)}};
    if (!probe_solved) {
      GS_LOG(INFO, "initialization auto: the solve from odometry ended unconverged after %d "
             "iterations (%s, chi2 %.6g): progressive initialization", summary.iterations,
             status.ok() ? summary.termination.c_str() : status.ToString().c_str(),
             summary.final_chi2);
      problem.poses = guess_poses;
      problem.features = guess_features;
      summary = core::SolverSummary();
    }
  }
  const double probe_seconds = Seconds(probe_start);
  const double probe_cpu_seconds = ProcessCpuSeconds() - probe_cpu_start;

  // Progressive initialization: growing prefixes of the trajectory, each
  // solved briefly, put the guess into the basin of the global optimum.
  const Clock::time_point progressive_start = Clock::now();
  partition::ProgressiveInitializationOptions progressive;
  progressive.enabled = (options.initialization == "progressive" ||
                         (options.initialization == "auto" && !probe_solved)) &&
                        !resuming && !streaming && root;
  progressive.max_observations_per_chunk = options.chunk_observations;
  progressive.max_new_poses = options.progressive_max_new_poses;
  if (Status status = progressive.Validate(); !status.ok()) {
    std::fprintf(stderr, "graphslam solve: %s\n", status.ToString().c_str());
    return kExitUsage;
  }
  partition::ProgressiveSummary progressive_summary;
  if (Status status = partition::InitializeProgressively(progressive, solver_options, &problem,
                                                         &progressive_summary);
      !status.ok())
    return fail(status);
  // Streaming mode: the pose-graph initializer (no in-memory sub-problems);
  // --initialization pose-graph asks for it in memory too.
  if (!resuming && root && ((streaming && (options.initialization == "progressive" ||
                                            options.initialization == "auto")) ||
                    options.initialization == "pose-graph")) {
    // Both first put the dead reckoning onto the GPS fixes, segment by segment:
    // far from them the pose-only LM creeps (20 000 poses: pose-only chi2
    // 6.4e6 -> 6.3e6 in 20 iterations unaligned, 6.9e7 -> 781 in 11 aligned;
    // store1e7: full chi2/dof 5.1e6 unaligned, 46 aligned; docs/benchmarks.md).
    // Without GPS nothing moves.
    {
      const partition::GpsAlignmentSummary aligned = partition::AlignOdometryToGps(&problem);
      GS_LOG(INFO, "GPS alignment: %lld chains, %lld segments, %lld poses moved",
             static_cast<long long>(aligned.chains), static_cast<long long>(aligned.segments),
             static_cast<long long>(aligned.poses_moved));
    }
    partition::PoseGraphInitializationSummary pose_graph;
    if (Status status = partition::InitializeFromPoseGraph(solver_options, 20, chunks, &problem,
                                                           &pose_graph);
        !status.ok())
      return fail(status);
    GS_LOG(INFO, "pose-graph initialization: %d iterations, pose-only chi2 %.6g -> %.6g, %lld "
           "features re-placed", pose_graph.iterations, pose_graph.initial_chi2,
           pose_graph.final_chi2, static_cast<long long>(pose_graph.placed_features));
  }
  const double progressive_seconds = Seconds(progressive_start);

  if (resuming) {
    // The solve continues from these estimates: moved into the problem, not
    // held twice (16 bytes per feature for the whole solve).
    if (resume_state.features.size() == problem.features.size() && !problem.features.empty()) {
      problem.features = std::move(resume_state.features);
      resume_state.features = {};
    }
    solver_options.resume_from = &resume_state;
  }
  // Streaming mode keeps no per-feature array of candidates (they go to a
  // scratch file beside the checkpoint, storage/candidate_file.h) and writes
  // the checkpoint's feature estimates as a binary file, not JSON arrays.
  // (Not under mpirun: every rank would use the same scratch files.)
  std::unique_ptr<storage::CandidateFile> candidate_file;
  if (streaming && !checkpoint_path.empty() && !distributed) {
    candidate_file = std::make_unique<storage::CandidateFile>(
        storage::Env::Default(), checkpoint_path + ".candidates.bin");
    solver_options.candidate_store = candidate_file.get();
  }
  // Streaming mode also parks the feature ids in a scratch file beside the
  // checkpoint while it solves (8 B per feature, the passes' peak included):
  // only the outputs read them (storage/feature_id_file.h).
  std::unique_ptr<storage::FeatureIdFile> id_file;
  if (streaming && !checkpoint_path.empty() && !distributed) {
    id_file = std::make_unique<storage::FeatureIdFile>(storage::Env::Default(),
                                                       checkpoint_path + ".ids.bin");
    if (Status status = id_file->Park(&problem.feature_ids); !status.ok()) return fail(status);
  }
  if (!checkpoint_path.empty()) {
    solver_options.checkpoint_callback = [&](const core::SolverCheckpoint& checkpoint) {
      if (streaming)
        return storage::WriteSolverCheckpointWithFeatureFile(
            storage::Env::Default(), checkpoint_path, options.input, checkpoint);
      return storage::WriteSolverCheckpoint(storage::Env::Default(), checkpoint_path,
                                            options.input, checkpoint);
    };
  }
  const double optimize_cpu_start = ProcessCpuSeconds();
  partition::AssociationOptions association;
  partition::AssociationSummary association_summary;
  nlohmann::json distributed_report = nlohmann::json::object();
  if (options.associate) {
    association.chi = options.chi;
    association.search_radius = options.association_radius;
    association.chunk_observations = options.chunk_observations;
    if (Status status = partition::AssociateAndSolve(association, solver_options, &problem,
                                                     &association_summary);
        !status.ok())
      return fail(status);
    summary = association_summary.final_solve;
    // A chunk store gets the associated problem (tools/association_store.h).
    if (store) {
      if (Status status = RewriteAssociatedChunkStore(storage::Env::Default(), store_path,
                                                      problem, options.chunk_observations,
                                                      store->source(), store->input());
          !status.ok())
        return fail(status);
    }
  } else if (distributed) {
    if (Status status = distributed->Solve(solver_options, *store, &problem, &summary,
                                           &distributed_report);
        !status.ok())
      return fail(status);
  } else if (!probe_solved) {
    if (Status status = core::SolveGraphSlam(solver_options, chunks, &problem, &summary);
        !status.ok()) {
      // A numerical failure names the input it happened on; nothing is
      // written (exit 5, not 4: tools/exit_codes.h).
      return fail(status.IsNumerical() ? status.WithContext(options.input + ": solve") : status);
    }
  }
  // A kept probe was the optimization.
  const double optimize_cpu_seconds =
      probe_solved ? probe_cpu_seconds : ProcessCpuSeconds() - optimize_cpu_start;
  display.Finish();
  if (id_file) {
    if (Status status = id_file->Restore(&problem.feature_ids); !status.ok()) return fail(status);
  }

  // Write outputs (each atomically); under mpirun rank 0 only.
  if (!root) return summary.converged ? kExitOk : kExitNotConverged;
  if (!options.output_g2o.empty()) {
    if (Status status = storage::WriteG2o(problem, options.output_g2o); !status.ok())
      return fail(status);
  }
  if (!options.tum.empty()) {
    if (Status status = storage::WriteTum(problem, options.tum); !status.ok()) return fail(status);
  }
  if (!options.features_csv.empty()) {
    if (Status status = storage::WriteFeaturesCsv(problem, options.features_csv, &summary.excluded);
        !status.ok())
      return fail(status);
  }
  const double total_seconds = Seconds(start);
  if (!options.report.empty()) {
    nlohmann::json report = BuildReport(options, problem, summary, format_name,
                                              read_seconds, initialize_seconds,
                                              progressive_seconds, total_seconds,
                                              num_observations);
    report["streaming"] = streaming;
    if (std::isfinite(input_chi2)) report["input_chi2"] = input_chi2;
    // -o renumbers features past the largest pose id when the ids collide
    // (storage/g2o_writer.h): the written id is the feature id plus this.
    if (!options.output_g2o.empty()) {
      StatusOr<int64_t> offset = storage::G2oFeatureIdOffset(problem);
      if (offset.ok()) report["g2o_feature_id_offset"] = *offset;
    }
    // What --initialization auto did: the solve from odometry (the final one
    // when it converged), or progressive initialization after it.
    report["initialization_used"] =
        options.initialization != "auto" ? options.initialization
        : streaming                      ? "pose-graph"
        : probe_solved                   ? "odometry"
                                         : "progressive";
    if (probe) {
      report["odometry_attempt"] = probe_report;
      report["stage_seconds"]["odometry_attempt"] = probe_seconds;
    }
    // CPU seconds (user + system, all threads) of the optimization and of the
    // whole process so far: on a shared machine the cost, where wall time
    // also counts the waits for a core.
    report["optimize_cpu_seconds"] = optimize_cpu_seconds;
    report["cpu_seconds"] = ProcessCpuSeconds();
    report["chunks_in_flight"] = solver_options.max_chunks_in_flight;
    report["memory_limit_bytes"] = memory_limit;
    if (store) report["store"] = store_path;
    if (distributed) report["distributed"] = distributed_report["distributed"];
    if (format_name == std::string_view("mrclam"))
      report["mrclam"] = {{"robot_measurements_dropped", mrclam_stats.robot_measurements_dropped},
                          {"out_of_time_range_dropped", mrclam_stats.out_of_time_range_dropped},
                          {"unknown_barcodes_skipped", mrclam_stats.unknown_barcodes_skipped},
                          {"unknown_barcode_lines", mrclam_stats.unknown_barcode_lines}};
    if (options.associate)
      report["association"] = BuildAssociationReport(association, association_summary, 200);
    if (Status status = storage::WriteStringAtomically(storage::Env::Default(), options.report,
                                                       report.dump(2) + "\n");
        !status.ok())
      return fail(status);
  }

  if (!quiet) {
    // With an output on standard output ("-"), the summary goes to stderr.
    std::FILE* const out = WritesToStandardOutput(options) ? stderr : stdout;
    std::fprintf(out, "graphslam solve summary\n");
    std::fprintf(out, "  input              %s (%s)\n", options.input.c_str(), format_name);
    std::fprintf(out, "  poses / features   %d / %d (%lld eliminated, %lld excluded)\n",
                problem.num_poses(), problem.num_features(),
                static_cast<long long>(summary.eliminated_features),
                static_cast<long long>(summary.excluded_features));
    std::fprintf(out, "  observations       %lld%s\n", static_cast<long long>(num_observations),
                streaming ? " (streamed from disk)" : "");
    if (options.associate) {
      std::fprintf(out, "  association        %lld -> %lld features, %lld merges (%lld undone), "
                  "%zu rounds, %.3f s\n",
                  static_cast<long long>(association_summary.initial_features),
                  static_cast<long long>(association_summary.final_features),
                  static_cast<long long>(association_summary.merges),
                  static_cast<long long>(association_summary.undone),
                  association_summary.rounds.size(), association_summary.seconds);
      const partition::IncrementalAssociationSummary& inc = association_summary.incremental;
      if (inc.ran) {
        std::fprintf(out, "  incremental pass   %lld stages, %lld features found, %lld provisional "
                    "dropped as clutter (%lld observations); solve %.2f s, covariances %.2f s, "
                    "assignment %.2f s\n",
                    static_cast<long long>(inc.stages), static_cast<long long>(inc.features),
                    static_cast<long long>(inc.provisional_dropped),
                    static_cast<long long>(inc.clutter_observations), inc.solve_seconds,
                    inc.covariance_seconds, inc.assignment_seconds);
      }
    }
    if (std::isfinite(input_chi2))
      std::fprintf(out, "  input chi2         %.9g (the input's own estimate)\n", input_chi2);
    PrintSolverSummaryLines(out, summary, total_seconds);
  }
  return summary.converged ? kExitOk : kExitNotConverged;
}

}  // namespace graphslam::tools

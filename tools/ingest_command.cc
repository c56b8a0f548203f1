#include "tools/ingest_command.h"

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cstdio>
#include <memory>
#include <utility>

#include "core/logging.h"
#include "partition/ingest/streaming_ingest.h"
#include "storage/chunk_store.h"
#include "storage/env.h"
#include "storage/store_directory.h"
#include "storage/format_detection.h"
#include "tools/distributed_solve_command.h"
#include "tools/exit_codes.h"
#include "tools/option_checks.h"
#include "tools/output_paths.h"
#include "tools/memory_budget.h"
#include "tools/memory_size.h"
#include "tools/out_of_core_solve.h"
#include "tools/resource_usage.h"

namespace graphslam::tools {

void AddIngestCommand(CLI::App* app, IngestCommandOptions* options, int* exit_code) {
  CLI::App* ingest = app->add_subcommand(
      "ingest",
      "Write an input (g2o, iSAM, TORO .graph, MRCLAM folder, native log) as a chunk store");
  ingest->add_option("input", options->input, "input file or MRCLAM dataset folder")->required();
  ingest->add_option("-o,--output", options->output_dir, "store directory")->required();
  ingest->add_option("--format", options->format, "input format: auto, g2o, isam, mrclam, native, toro")
      ->capture_default_str();
  ingest->add_option("--robot", options->robot, "MRCLAM robot number")
      ->check(Integer(1, 5))
      ->capture_default_str();
  ingest->add_option("--chunk-observations", options->chunk_observations,
                     "observations per chunk (feature-complete)")
      ->check(Integer(1))
      ->capture_default_str();
  ingest->add_option("--memory-limit", options->memory_limit,
                     "peak memory of the ingest (e.g. 512M, 2G): refused at the start if "
                     "below the estimated need; the observation buffer gets the rest");
  ingest->add_option("--buffer-observations", options->buffer_observations,
                     "observations held in memory at once (overrides --memory-limit)")
      ->check(Integer(0));
  ingest->add_flag("--compress", options->compress, "zstd-compress chunk blocks");
  ingest->add_flag("--resume", options->resume,
                   "continue an interrupted ingest of the same native log into STORE from its "
                   "last checkpoint (else start afresh)");
  ingest->add_option("--checkpoint-seconds", options->checkpoint_seconds,
                     "least time between two checkpoints of the second pass (0: every spill)")
      ->check(NonNegativeReal())
      ->capture_default_str();
  ingest->add_option("--scan-chunk-size", options->scan_chunk_size,
                     "target size of a scan chunk file in STORE/scans/ (e.g. 256K, 16M)")
      ->capture_default_str();
  ingest->add_flag("-q,--quiet", options->quiet, "no summary on the terminal");
  ingest->add_flag("-v,--verbose", options->verbosity, "more log detail (repeatable)");
  ingest->callback([options, exit_code]() { *exit_code = RunIngestCommand(*options); });
}

namespace {

// The summary `graphslam ingest` prints on standard output (rank 0 only).
void PrintIngestSummary(const IngestCommandOptions& options, storage::InputFormat format,
                        const partition::StreamingIngestOptions& ingest,
                        const partition::IngestSummary& summary) {
  std::printf("graphslam ingest summary\n");
  std::printf("  input              %s (%s%s)\n", options.input.c_str(),
              storage::InputFormatName(format), summary.streamed ? ", streamed" : ", read whole");
  std::printf("  store              %s\n", options.output_dir.c_str());
  if (summary.resumed_stage == "spill")
    std::printf("  resumed            second pass, after %lld observations\n",
                static_cast<long long>(summary.resumed_from_observation));
  else if (summary.resumed_stage == "chunks")
    std::printf("  resumed            after %lld durable chunks\n",
                static_cast<long long>(summary.resumed_from_chunk));
  std::printf("  poses / features   %d / %d\n", summary.poses, summary.features);
  std::printf("  observations       %lld in %lld chunks\n",
              static_cast<long long>(summary.observations),
              static_cast<long long>(summary.chunks));
  if (ingest.ranks.size > 1)
    std::printf("  ranks              %d, one shard of chunks each\n", ingest.ranks.size);
  if (summary.scans.scans > 0)
    std::printf("  scans              %lld (%lld points) in %lld chunks in %s/scans%s\n",
                static_cast<long long>(summary.scans.scans),
                static_cast<long long>(summary.scans.points),
                static_cast<long long>(summary.scans.chunks), options.output_dir.c_str(),
                summary.scans.resumed_from_scan > 0 ? " (resumed)" : "");
  std::printf("  buckets / spills   %lld / %lld (buffer %lld observations, peak %lld held)\n",
              static_cast<long long>(summary.bucketing.buckets),
              static_cast<long long>(summary.bucketing.spills),
              static_cast<long long>(ingest.buffer_observations),
              static_cast<long long>(summary.bucketing.peak_observations_in_memory));
  if (summary.streamed)
    std::printf("  scratch            %.1f MB replay written, %.1f MB read; %.1f MB spilled\n",
                summary.replay_bytes_written / 1e6, summary.replay_bytes_read / 1e6,
                summary.bucketing.spilled_bytes / 1e6);
  std::printf("  peak RSS           %.1f MiB\n", PeakRssBytes() / (1024.0 * 1024.0));
}

// Under mpirun with N > 1: N ranks write one store, a shard of its chunks
// each (partition::IngestRanks); rank 0 is the writer the lock knows.
StatusOr<std::unique_ptr<DistributedSolveRun>> JoinRanks(
    partition::StreamingIngestOptions* ingest) {
  GS_ASSIGN_OR_RETURN(std::unique_ptr<DistributedSolveRun> distributed,
                      DistributedSolveRun::Start(""));
  DistributedSolveRun* run = distributed.get();
  ingest->ranks.rank = run->rank();
  ingest->ranks.size = run->size();
  ingest->ranks.barrier = [run] { run->Barrier(); };
  ingest->ranks.gather = [run](std::vector<storage::ChunkStoreEntry>* entries,
                               std::vector<storage::ChunkStoreShard>* shards) {
    return run->GatherChunkEntries(entries, shards);
  };
  return distributed;
}

// The ingest's options from the command's: the format (--format, or
// detected), the --memory-limit budget (checked before anything is read;
// --buffer-observations overrides the buffer it leaves, not the check), the
// chunk and scan-chunk sizes, --resume and checkpoints. *usage is set when
// the error is a bad option (exit 1) rather than a failure.
StatusOr<partition::StreamingIngestOptions> PlanIngest(const IngestCommandOptions& options,
                                                       bool* usage) {
  const auto bad_option = [usage](const std::string& message) {
    *usage = true;
    return Status::InvalidArgument(message);
  };
  storage::InputFormat format;
  if (options.format == "auto") {
    GS_ASSIGN_OR_RETURN(format, storage::DetectInputFormat(options.input));
  } else {
    StatusOr<storage::InputFormat> parsed = storage::ParseInputFormat(options.format);
    if (!parsed.ok()) return bad_option("--format: " + parsed.status().ToString());
    format = *parsed;
  }
  partition::StreamingIngestOptions ingest;
  ingest.format = format;
  ingest.mrclam.robot = options.robot;
  ingest.max_observations_per_chunk = options.chunk_observations;
  int64_t limit = 0;
  if (!options.memory_limit.empty()) {
    StatusOr<int64_t> parsed = ParseMemorySize(options.memory_limit);
    if (!parsed.ok()) return bad_option("--memory-limit: " + parsed.status().ToString());
    limit = *parsed;
  }
  GS_ASSIGN_OR_RETURN(const IngestInput estimate, EstimateIngestInput(options.input, format));
  GS_ASSIGN_OR_RETURN(const IngestBudget budget,
                      BudgetIngest(limit, estimate, options.chunk_observations));
  ingest.buffer_observations = options.buffer_observations > 0 ? options.buffer_observations
                                                               : budget.buffer_observations;
  ingest.buffer_observations = std::max(ingest.buffer_observations, options.chunk_observations);
  ingest.expected = estimate.Expected();
  ingest.store.source = options.input;
  if (options.compress) ingest.store.chunk.compression = storage::ChunkCompression::kZstd;
  if (options.checkpoint_seconds < 0)
    return bad_option("--checkpoint-seconds must be >= 0, got " +
                      std::to_string(options.checkpoint_seconds));
  StatusOr<int64_t> scan_chunk = ParseMemorySize(options.scan_chunk_size);
  if (!scan_chunk.ok() || *scan_chunk <= 0)
    return bad_option("--scan-chunk-size: expected a size > 0 such as 256K or 16M, got '" +
                      options.scan_chunk_size + "'");
  ingest.scan_chunk_bytes = *scan_chunk;
  ingest.resume = options.resume;
  ingest.checkpoint_seconds = options.checkpoint_seconds;
  return ingest;
}

}  // namespace

int RunIngestCommand(const IngestCommandOptions& options) {
  SetLogVerbosity(options.verbosity);
  SetQuietLogging(options.quiet);
  // Under mpirun (docs/distributed.md) a failure of one rank ends them all:
  // the others may be waiting for it in a collective call.
  std::unique_ptr<DistributedSolveRun> distributed;
  auto fail = [&distributed](const Status& status) {
    std::fprintf(stderr, "graphslam ingest: %s\n", status.ToString().c_str());
    if (distributed != nullptr) distributed->Abort(ExitCodeFor(status));
    return ExitCodeFor(status);
  };
  auto usage = [](const std::string& message) {
    std::fprintf(stderr, "graphslam ingest: %s\n", message.c_str());
    return kExitUsage;
  };
  if (options.input.empty()) return usage("no INPUT given");
  if (options.output_dir.empty()) return usage("no -o STORE given");
  if (options.chunk_observations <= 0)
    return usage("--chunk-observations must be > 0, got " +
                 std::to_string(options.chunk_observations));

  if (Status status = CheckOutputPaths({{"-o", options.output_dir, /*folder=*/true}});
      !status.ok())
    return fail(status);
  bool bad_option = false;
  StatusOr<partition::StreamingIngestOptions> planned = PlanIngest(options, &bad_option);
  if (!planned.ok())
    return bad_option ? usage(planned.status().message()) : fail(planned.status());
  partition::StreamingIngestOptions ingest = std::move(planned).value();
  if (LaunchedProcesses() > 1) {  // under mpirun: one shard of chunks per rank
    if (options.resume) return usage("--resume is not supported under mpirun");
    StatusOr<std::unique_ptr<DistributedSolveRun>> started = JoinRanks(&ingest);
    if (!started.ok()) return fail(started.status());
    distributed = std::move(started).value();
  }
  const bool root = ingest.ranks.rank == 0;
  // One writer per store: the exclusive lock, held to the end; a folder that
  // is not ours is refused before anything is written. Under mpirun rank 0
  // holds it for the job (the other ranks take none: theirs would fight it).
  storage::DirectoryLock lock;
  if (root) {
    StatusOr<storage::DirectoryLock> locked =
        storage::OpenStoreForWriting(storage::Env::Default(), options.output_dir);
    if (!locked.ok()) return fail(locked.status());
    lock = std::move(locked).value();
  }
  partition::IngestSummary summary;
  if (Status status = partition::IngestToStore(storage::Env::Default(), options.input,
                                               options.output_dir, ingest, &summary);
      !status.ok())
    return fail(status);

  if (!options.quiet && root) PrintIngestSummary(options, ingest.format, ingest, summary);
  return kExitOk;
}

}  // namespace graphslam::tools

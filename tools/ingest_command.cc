#include "tools/ingest_command.h"

#include <cstdio>
#include <utility>

#include "core/initialization.h"
#include "core/unidentified_features.h"
#include "partition/in_memory_chunk_source.h"
#include "storage/chunk_store.h"
#include "storage/env.h"
#include "storage/format_detection.h"
#include "tools/exit_codes.h"

namespace graphslam::tools {

void AddIngestCommand(CLI::App* app, IngestCommandOptions* options, int* exit_code) {
  CLI::App* ingest = app->add_subcommand(
      "ingest", "Write an input (g2o, iSAM, MRCLAM folder, native log) as a chunk store");
  ingest->add_option("input", options->input, "input file or MRCLAM dataset folder")->required();
  ingest->add_option("-o,--output", options->output_dir, "store directory")->required();
  ingest->add_option("--format", options->format, "input format: auto, g2o, isam, mrclam, native")
      ->capture_default_str();
  ingest->add_option("--robot", options->robot, "MRCLAM robot number")->capture_default_str();
  ingest->add_option("--chunk-observations", options->chunk_observations,
                     "observations per chunk (feature-complete)")
      ->capture_default_str();
  ingest->add_flag("--compress", options->compress, "zstd-compress chunk blocks");
  ingest->add_flag("-q,--quiet", options->quiet, "no summary on the terminal");
  ingest->callback([options, exit_code]() { *exit_code = RunIngestCommand(*options); });
}

int RunIngestCommand(const IngestCommandOptions& options) {
  auto fail = [](const Status& status) {
    std::fprintf(stderr, "graphslam ingest: %s\n", status.ToString().c_str());
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

  storage::InputFormat format;
  if (options.format == "auto") {
    StatusOr<storage::InputFormat> detected = storage::DetectInputFormat(options.input);
    if (!detected.ok()) return fail(detected.status());
    format = *detected;
  } else {
    StatusOr<storage::InputFormat> parsed = storage::ParseInputFormat(options.format);
    if (!parsed.ok()) return usage("--format: " + parsed.status().ToString());
    format = *parsed;
  }
  storage::MrclamOptions mrclam;
  mrclam.robot = options.robot;
  StatusOr<core::Problem2d> read = storage::ReadProblem(options.input, format, mrclam);
  if (!read.ok()) return fail(read.status());
  if (const core::UnidentifiedObservations unidentified =
          core::CountUnidentifiedObservations(*read);
      unidentified.count > 0) {
    return fail(Status::NotSupported(
        options.input + ":" + std::to_string(unidentified.first_line) + ": " +
        std::to_string(unidentified.count) +
        " observations have no feature id; expected ids (a chunk store needs feature-complete "
        "chunks; use graphslam solve --associate on the input instead)"));
  }
  core::Problem2d problem = std::move(read).value();
  if (Status status = core::InitializeProblem(&problem); !status.ok()) return fail(status);

  partition::ChunkingOptions chunking;
  chunking.max_observations_per_chunk = options.chunk_observations;
  const partition::InMemoryChunkSource chunks(problem, chunking);
  storage::ChunkStoreWriteOptions store_options;
  store_options.source = options.input;
  if (options.compress) store_options.chunk.compression = storage::ChunkCompression::kZstd;
  if (Status status = storage::WriteChunkStore(storage::Env::Default(), options.output_dir,
                                               problem, chunks, store_options);
      !status.ok())
    return fail(status);

  if (!options.quiet) {
    std::printf("graphslam ingest summary\n");
    std::printf("  input              %s (%s)\n", options.input.c_str(),
                storage::InputFormatName(format));
    std::printf("  store              %s\n", options.output_dir.c_str());
    std::printf("  poses / features   %d / %d\n", problem.num_poses(), problem.num_features());
    std::printf("  observations       %zu in %lld chunks\n", problem.observations.size(),
                static_cast<long long>(chunks.NumChunks()));
  }
  return kExitOk;
}

}  // namespace graphslam::tools

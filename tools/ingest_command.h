// `graphslam ingest INPUT -o STORE/ ...`: reads any supported input (g2o,
// iSAM, MRCLAM folder, native log; storage/format_detection.h), initializes it
// (paper Table 1, core/initialization.h), cuts its observations into
// feature-complete chunks (partition/in_memory_chunk_source.h) and writes a
// chunk store (storage/chunk_store.h, docs/formats/chunk_store.md) that
// `graphslam solve STORE/` reads.
//
// Bad options exit with kExitUsage and bad input with kExitBadInput before
// anything is written; the store's MANIFEST.json is written last, so an
// interrupted ingest leaves a store every reader rejects (tools/exit_codes.h).
//
// Memory: this version reads the whole input into memory (the external,
// bounded-memory bucketing of issue 3 is not done yet).
#pragma once

#include <cstdint>
#include <string>

#include <CLI/CLI.hpp>

namespace graphslam::tools {

struct IngestCommandOptions {
  std::string input;
  std::string output_dir;        // -o STORE/
  std::string format = "auto";   // auto, g2o, isam, mrclam, native
  int robot = 1;                 // MRCLAM robot number
  int64_t chunk_observations = 4096;
  bool compress = false;         // zstd per block
  bool quiet = false;
};

// Registers the subcommand on `app`; the callback stores the exit code in *exit_code.
void AddIngestCommand(CLI::App* app, IngestCommandOptions* options, int* exit_code);

// Ingests; returns the process exit code (tools/exit_codes.h).
int RunIngestCommand(const IngestCommandOptions& options);

}  // namespace graphslam::tools

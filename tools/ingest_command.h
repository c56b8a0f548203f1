// `graphslam ingest INPUT -o STORE/ ...`: reads any supported input (g2o,
// iSAM, MRCLAM folder, native log; storage/format_detection.h), initializes it
// (paper Table 1, core/initialization.h), cuts its observations into
// feature-complete chunks by external bucketing (partition/ingest/streaming_ingest.h)
// and writes a chunk store (storage/chunk_store.h, docs/formats/chunk_store.md)
// that `graphslam solve STORE/` reads.
//
// Bad options exit with kExitUsage and bad input with kExitBadInput before
// anything is written; the store's MANIFEST.json is written last, so an
// interrupted ingest leaves a store every reader rejects (tools/exit_codes.h).
// --resume continues an interrupted ingest of a native log from its last
// checkpoint (STORE/work/, docs/formats/ingest_progress.md) and gives the
// store an uninterrupted ingest gives, byte for byte.
//
// Memory: for native logs O(poses + features) plus a bounded buffer of
// observations; other formats are read whole by their readers first
// (docs/out_of_core.md). --memory-limit bounds the whole peak
// (tools/memory_budget.h): refused at the start if below the estimated need,
// else the buffer gets what is left (--buffer-observations overrides it).
#pragma once

#include <cstdint>
#include <string>

#include "tools/cli_fwd.h"

namespace graphslam::tools {

struct IngestCommandOptions {
  std::string input;
  std::string output_dir;        // -o STORE/
  std::string format = "auto";   // auto, g2o, isam, mrclam, native
  int robot = 1;                 // MRCLAM robot number
  int64_t chunk_observations = 4096;
  int64_t buffer_observations = 0;  // 0: from memory_limit
  std::string memory_limit;      // peak budget (tools/memory_budget.h); "": buffer from 1 GiB
  bool compress = false;         // zstd per block
  bool resume = false;           // continue a killed ingest (native logs)
  double checkpoint_seconds = 30.0;  // least time between pass-2 checkpoints
  std::string scan_chunk_size = "16M";  // target size of a scan chunk (STORE/scans/)
  bool quiet = false;
  int verbosity = 0;  // -v, repeatable (GS_VLOG level)
};

// Registers the subcommand on `app`; the callback stores the exit code in *exit_code.
void AddIngestCommand(CLI::App* app, IngestCommandOptions* options, int* exit_code);

// Ingests; returns the process exit code (tools/exit_codes.h).
int RunIngestCommand(const IngestCommandOptions& options);

}  // namespace graphslam::tools

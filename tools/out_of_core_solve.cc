#include "tools/out_of_core_solve.h"

#include <filesystem>
#include <system_error>

#include "core/logging.h"
#include "partition/ingest/streaming_ingest.h"
#include "storage/chunk_store.h"
#include "storage/env.h"
#include "storage/file_checksum.h"
#include "storage/format_detection.h"
#include "tools/memory_budget.h"

namespace graphslam::tools {

bool WorkdirStoreIsCurrent(const std::string& input, const std::string& workdir) {
  if (!storage::IsChunkStore(workdir)) return false;
  StatusOr<std::unique_ptr<storage::DiskChunkSource>> store = storage::DiskChunkSource::Open(workdir);
  if (!store.ok() || (*store)->source() != input || (*store)->input().bytes < 0) return false;
  StatusOr<storage::FileChecksum> identity = storage::IdentifyInput(input);
  return identity.ok() && *identity == (*store)->input();
}

Status IngestIntoWorkdir(const std::string& input, const std::string& format, int robot,
                         const std::string& workdir, int64_t chunk_observations,
                         int64_t memory_limit_bytes, bool resume) {
  partition::StreamingIngestOptions options;
  if (format == "auto") {
    GS_ASSIGN_OR_RETURN(options.format, storage::DetectInputFormat(input));
  } else {
    GS_ASSIGN_OR_RETURN(options.format, storage::ParseInputFormat(format));
  }
  options.mrclam.robot = robot;
  options.max_observations_per_chunk = chunk_observations;
  GS_ASSIGN_OR_RETURN(const IngestInput estimate, EstimateIngestInput(input, options.format));
  GS_ASSIGN_OR_RETURN(const IngestBudget budget,
                      BudgetIngest(memory_limit_bytes, estimate, chunk_observations));
  options.buffer_observations = budget.buffer_observations;
  options.expected = estimate.Expected();
  options.store.source = input;
  options.resume = resume;
  options.copy_scans = false;  // the solve needs no scans (graphslam ingest copies them)
  partition::IngestSummary summary;
  GS_RETURN_IF_ERROR(
      partition::IngestToStore(storage::Env::Default(), input, workdir, options, &summary));
  GS_LOG(INFO, "ingested %s into %s: %lld observations in %lld chunks", input.c_str(),
         workdir.c_str(), static_cast<long long>(summary.observations),
         static_cast<long long>(summary.chunks));
  return Status::Ok();
}

}  // namespace graphslam::tools

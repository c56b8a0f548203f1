#include "tools/out_of_core_solve.h"

#include <algorithm>
#include <filesystem>
#include <system_error>

#include "core/problem.h"
#include "core/logging.h"
#include "partition/streaming_ingest.h"
#include "storage/chunk_store.h"
#include "storage/env.h"
#include "storage/file_checksum.h"
#include "storage/format_detection.h"

namespace graphslam::tools {

StatusOr<int> ChunksInFlightForMemoryLimit(int64_t limit_bytes, int64_t poses, int64_t features,
                                           int64_t chunk_observations, int default_in_flight,
                                           bool streaming) {
  if (limit_bytes <= 0) return default_in_flight;
  const int64_t pose_system =
      poses * kPoseSystemBytesPerPose +
      features * (streaming ? kBytesPerFeatureStreaming : kBytesPerFeature);
  const int64_t chunk = chunk_observations * kBytesPerObservationInFlight;
  const int64_t left = limit_bytes - pose_system;
  if (left < chunk)
    return Status::InvalidArgument(
        "--memory-limit " + std::to_string(limit_bytes) + " bytes is below the estimated need of " +
        std::to_string(pose_system + chunk) + " bytes (pose system " + std::to_string(pose_system) +
        " + one chunk of " + std::to_string(chunk_observations) + " observations " +
        std::to_string(chunk) + "); raise it or lower --chunk-observations");
  return static_cast<int>(std::clamp<int64_t>(left / chunk, 1, default_in_flight));
}

int64_t IngestBufferObservations(int64_t limit_bytes, int64_t chunk_observations) {
  if (limit_bytes <= 0) limit_bytes = int64_t{1} << 30;
  return std::max(chunk_observations,
                  limit_bytes / (3 * static_cast<int64_t>(sizeof(core::Observation))));
}

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
  options.buffer_observations = IngestBufferObservations(memory_limit_bytes, chunk_observations);
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

#include "partition/streaming_ingest.h"

#include <filesystem>
#include <memory>
#include <system_error>
#include <utility>
#include <vector>

#include "core/initialization.h"
#include "core/unidentified_features.h"
#include "storage/native_log_reader.h"

namespace graphslam::partition {

Status IngestToStore(storage::Env* env, const std::string& input, const std::string& store_dir,
                     const StreamingIngestOptions& options, IngestSummary* summary) {
  GS_CHECK(env != nullptr && summary != nullptr);
  *summary = IngestSummary();
  GS_RETURN_IF_ERROR(options.store.Validate());
  const std::filesystem::path dir(store_dir);
  const std::string work = (dir / kIngestWorkDirectory).string();
  ExternalBucketingOptions bucketing;
  bucketing.max_observations_per_chunk = options.max_observations_per_chunk;
  bucketing.buffer_observations = options.buffer_observations;
  bucketing.work_dir = work;
  GS_RETURN_IF_ERROR(bucketing.Validate());

  // 1. Un-commit before reading anything: a kill from here on leaves a
  // directory without MANIFEST.json, i.e. an incomplete store.
  std::error_code error;
  std::filesystem::create_directories(dir, error);
  if (error) return Status::IOError(store_dir + ": mkdir: " + error.message());
  const std::string manifest = (dir / storage::kChunkStoreManifestName).string();
  if (env->FileExists(manifest)) {
    GS_RETURN_IF_ERROR(env->RemoveFile(manifest));
    GS_RETURN_IF_ERROR(env->SyncDirectory(store_dir));
  }
  std::filesystem::remove_all(work, error);
  if (error) return Status::IOError(work + ": remove: " + error.message());
  std::filesystem::create_directories(work, error);
  if (error) return Status::IOError(work + ": mkdir: " + error.message());

  // 2. Pass 1.
  FeatureIndex index;
  InitializationObservations init;
  const storage::ObservationSink pass1 = [&](const core::Observation& observation) {
    index.Add(observation);
    init.Add(observation);
    return Status::Ok();
  };
  core::Problem2d problem;
  ObservationReplay replay;
  if (options.format == storage::InputFormat::kNative) {
    GS_ASSIGN_OR_RETURN(problem, storage::ReadNativeLogStreaming(input, pass1));
    replay = [&input](const storage::ObservationSink& sink) {
      return storage::ReadNativeLogStreaming(input, sink).status();
    };
    summary->streamed = true;
  } else {
    GS_ASSIGN_OR_RETURN(problem, storage::ReadProblem(input, options.format, options.mrclam));
    if (const core::UnidentifiedObservations unidentified =
            core::CountUnidentifiedObservations(problem);
        unidentified.count > 0) {
      return Status::NotSupported(
          input + ":" + std::to_string(unidentified.first_line) + ": " +
          std::to_string(unidentified.count) +
          " observations have no feature id; expected ids (a chunk store needs feature-complete "
          "chunks; use graphslam solve --associate on the input instead)");
    }
    auto observations =
        std::make_shared<std::vector<core::Observation>>(std::move(problem.observations));
    problem.observations.clear();
    for (const core::Observation& observation : *observations)
      GS_RETURN_IF_ERROR(pass1(observation));
    replay = [observations](const storage::ObservationSink& sink) {
      for (const core::Observation& observation : *observations)
        GS_RETURN_IF_ERROR(sink(observation));
      return Status::Ok();
    };
  }
  // The streaming native reader has no lines to give here; the count says enough.
  if (summary->streamed) {
    int64_t unidentified = 0;
    for (const int64_t id : problem.feature_ids) unidentified += id == core::kNoFeatureId;
    if (unidentified > 0)
      return Status::NotSupported(
          input + ": " + std::to_string(unidentified) +
          " observations have no feature id ('-'); expected ids (a chunk store needs "
          "feature-complete chunks; use graphslam solve --associate on the input instead)");
  }
  index.Resize(problem.num_features());

  // 3. Initialization on the kept observations, then back to pose-only.
  problem.observations = init.kept();
  GS_RETURN_IF_ERROR(core::InitializeProblem(&problem));
  problem.observations.clear();
  problem.observations.shrink_to_fit();

  // 4. Pass 2 and 5. the store.
  GS_ASSIGN_OR_RETURN(std::unique_ptr<BucketChunkSource> chunks,
                      BucketChunkSource::Build(index, replay, bucketing));
  GS_RETURN_IF_ERROR(storage::WriteChunkStore(env, store_dir, problem, *chunks, options.store));
  std::filesystem::remove_all(work, error);  // scratch only; a leftover is harmless

  summary->poses = problem.num_poses();
  summary->features = problem.num_features();
  summary->observations = index.observations();
  summary->chunks = chunks->NumChunks();
  summary->bucketing = chunks->stats();
  return Status::Ok();
}

}  // namespace graphslam::partition

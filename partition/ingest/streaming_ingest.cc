#include "partition/ingest/streaming_ingest.h"

#include <filesystem>
#include <future>
#include <memory>
#include <system_error>
#include <utility>
#include <vector>

#include "core/logging.h"
#include "core/unidentified_features.h"
#include "partition/initialization/first_sight_initialization.h"
#include "partition/ingest/ingest_progress.h"
#include "storage/chunk_store_writer.h"
#include "storage/file_checksum.h"
#include "storage/native_log_reader.h"
#include "storage/stop_point.h"
#include "storage/store_directory.h"

namespace graphslam::partition {
namespace {

// The identity and options a progress record must match to be resumed.
IngestProgress ThisIngest(const std::string& input, const storage::FileChecksum& identity,
                          const StreamingIngestOptions& options) {
  IngestProgress progress;
  progress.input = input;
  progress.input_bytes = identity.bytes;
  progress.input_crc32c = identity.crc32c;
  progress.chunk_observations = options.max_observations_per_chunk;
  progress.buffer_observations = options.buffer_observations;
  progress.compression = static_cast<int>(options.store.chunk.compression);
  progress.zstd_level = options.store.chunk.zstd_level;
  progress.target_record_bytes = options.store.chunk.target_record_bytes;
  progress.source = options.store.source;
  progress.replay_segment_observations = options.replay.segment_observations();
  return progress;
}

// Pass 1 and the initialization: the pose-only, initialized problem, the
// observation count, and (other formats) the replay of their observations.
// The FeatureIndex is in the pass-1 record on disk (PassOne reads it back).
struct FirstPass {
  core::Problem2d problem;
  int64_t observations = 0;
  ObservationReplay replay;  // set for formats read whole
  std::vector<storage::NativeLogScan> scans;  // native logs: SCAN records
  std::vector<core::Pose3> scan_poses;        // their scans' logged poses
};

// Native logs: every observation also goes to `replay` (pass 2 reads it back
// instead of the text); *replay_bytes gets the bytes it wrote.
StatusOr<FirstPass> RunFirstPass(storage::Env* env, const std::string& input,
                                 const std::string& work, const std::string& pass1_path,
                                 const StreamingIngestOptions& options, int64_t* replay_bytes) {
  FirstPass pass;
  FeatureIndex index;
  FirstSightInitialization init((std::filesystem::path(work) / kFirstSightScratchName).string());
  std::unique_ptr<ReplayFrameWriter> replay;
  const storage::ObservationSink pass1 = [&](const core::Observation& observation) {
    GS_RETURN_IF_ERROR(init.Add(observation, index));  // before the index counts it
    index.Add(observation);
    return replay ? replay->Add(observation) : Status::Ok();
  };
  if (options.format == storage::InputFormat::kNative) {
    replay = std::make_unique<ReplayFrameWriter>(work, options.replay);
    index.Reserve(options.expected.features);
    // The guesses are sized below, once the index is on disk.
    GS_ASSIGN_OR_RETURN(pass.problem,
                        storage::ReadNativeLogStreaming(input, pass1, &pass.scans, options.expected,
                                                        /*size_guesses=*/false));
    GS_RETURN_IF_ERROR(replay->Finish());  // durable before the first progress record
    *replay_bytes = replay->bytes_written();
    replay.reset();
    // The streaming native reader has no lines to give here; the count says enough.
    int64_t unidentified = 0;
    for (const int64_t id : pass.problem.feature_ids) unidentified += id == core::kNoFeatureId;
    if (unidentified > 0)
      return Status::NotSupported(
          input + ": " + std::to_string(unidentified) +
          " observations have no feature id ('-'); expected ids (a chunk store needs "
          "feature-complete chunks; use graphslam solve --associate on the input instead)");
  } else {
    GS_ASSIGN_OR_RETURN(pass.problem,
                        storage::ReadProblem(input, options.format, options.mrclam));
    if (const core::UnidentifiedObservations unidentified =
            core::CountUnidentifiedObservations(pass.problem);
        unidentified.count > 0) {
      return Status::NotSupported(
          input + ":" + std::to_string(unidentified.first_line) + ": " +
          std::to_string(unidentified.count) +
          " observations have no feature id; expected ids (a chunk store needs feature-complete "
          "chunks; use graphslam solve --associate on the input instead)");
    }
    auto observations =
        std::make_shared<std::vector<core::Observation>>(std::move(pass.problem.observations));
    pass.problem.observations.clear();
    for (const core::Observation& observation : *observations)
      GS_RETURN_IF_ERROR(pass1(observation));
    pass.replay = [observations](const storage::ObservationSink& sink) {
      for (const core::Observation& observation : *observations)
        GS_RETURN_IF_ERROR(sink(observation));
      return Status::Ok();
    };
  }
  // Exactly one entry per feature (Add grows to the highest feature
  // observed; features declared but never observed count 0): a resumed
  // ingest reads back the same index.
  const auto num_features = static_cast<int32_t>(pass.problem.feature_ids.size());
  index.Resize(num_features);
  GS_CHECK(index.counts().size() == static_cast<size_t>(num_features));

  pass.scan_poses = LoggedScanPoses(pass.problem, pass.scans);  // the guesses, as logged

  // The pass-1 record now, with the ids lent by the problem: the index (8 B
  // per feature) waits on disk while the initialization holds the guesses.
  pass.observations = index.observations();
  Pass1Record record;
  record.pose_ids = pass.problem.pose_ids;
  record.feature_ids = std::move(pass.problem.feature_ids);
  record.observations = pass.observations;
  index.Release(&record.counts, &record.first_pose);
  const Status written = WritePass1Record(env, pass1_path, record);
  pass.problem.feature_ids = std::move(record.feature_ids);
  record = Pass1Record();
  GS_RETURN_IF_ERROR(written);
  storage::StopPointForTests("ingest_index_on_disk");
  storage::SizeGuesses(&pass.problem);  // 17 B per feature from here

  // Table 1 from the first sights on disk and the joining observations.
  GS_RETURN_IF_ERROR(init.Initialize(&pass.problem));
  return pass;
}

// One ingest's paths and state, shared by its steps.
struct IngestRun {
  IngestRun(storage::Env* env_in, const std::string& input_in, const std::string& store_dir_in,
            const StreamingIngestOptions& options_in, IngestSummary* summary_in)
      : env(env_in), input(input_in), store_dir(store_dir_in), options(options_in),
        summary(summary_in) {}

  storage::Env* env;
  const std::string& input;
  const std::string& store_dir;
  const StreamingIngestOptions& options;
  IngestSummary* summary;
  bool root = true;     // rank 0 (or the only process)
  bool native = false;  // a native log: resumable, replayed from its frames
  std::string work, progress_path, pass1_path;
  IngestProgress progress;
  Pass1Record pass1;
  bool resuming = false;
  // A fresh ingest's input identity, computed beside pass 1 (set until
  // AwaitInputIdentity took it).
  std::future<StatusOr<storage::FileChecksum>> identity;
};

// The input's identity, once the checksum beside pass 1 is done: into the
// progress records and the writer's manifest.
Status AwaitInputIdentity(storage::ChunkStoreWriter* writer, IngestRun* run) {
  if (!run->identity.valid()) return Status::Ok();
  GS_ASSIGN_OR_RETURN(const storage::FileChecksum input, run->identity.get());
  run->progress.input_bytes = input.bytes;
  run->progress.input_crc32c = input.crc32c;
  writer->SetInput(input);
  return Status::Ok();
}

// A resumable record of this very ingest, or a fresh start (WORK emptied).
Status FindResumePoint(const storage::ChunkStoreWriteOptions& store_options, IngestRun* run) {
  if (run->native) {
    run->progress = ThisIngest(run->input, store_options.input, run->options);
    if (run->options.resume) {
      StatusOr<IngestProgress> recorded = ReadIngestProgress(run->progress_path);
      StatusOr<Pass1Record> record = ReadPass1Record(run->pass1_path);
      if (recorded.ok() && recorded->SameIngest(run->progress) && record.ok()) {
        run->progress = std::move(recorded).value();
        run->pass1 = std::move(record).value();
        run->resuming = true;
      } else {
        GS_LOG(WARNING, "%s: nothing to resume (%s); ingesting from the start",
               run->store_dir.c_str(),
               !recorded.ok()  ? recorded.status().ToString().c_str()
               : !record.ok() ? record.status().ToString().c_str()
                              : "the input or the options changed");
      }
    }
  }
  if (run->resuming) return Status::Ok();
  GS_RETURN_IF_ERROR(run->env->RemoveTree(run->work));
  GS_RETURN_IF_ERROR(run->env->CreateDir(run->work));
  if (run->root) GS_RETURN_IF_ERROR(RemoveIngestedScans(run->env, run->store_dir));
  return Status::Ok();
}

// Pass 1, the initialization and the problem file (or the recorded pass 1
// of a resume) into *index; *replay is pass 2's input when not native.
Status PassOne(storage::ChunkStoreWriter* writer, IngestRun* run, FeatureIndex* index,
               ObservationReplay* replay) {
  if (run->resuming) {
    index->Assign(std::move(run->pass1.counts), std::move(run->pass1.first_pose),
                  run->pass1.observations);
    run->pass1 = Pass1Record();
    run->summary->resumed_stage = run->progress.stage;
    return Status::Ok();
  }
  GS_ASSIGN_OR_RETURN(FirstPass first,
                      RunFirstPass(run->env, run->input, run->work, run->pass1_path, run->options,
                                   &run->summary->replay_bytes_written));
  GS_RETURN_IF_ERROR(AwaitInputIdentity(writer, run));  // before the first progress record
  if (run->native && run->options.copy_scans && run->root)
    GS_RETURN_IF_ERROR(
        SaveScanRecords(run->env, run->input, run->work, first.scans, first.scan_poses));
  if (run->root) GS_RETURN_IF_ERROR(writer->WriteProblem(first.problem));
  *replay = std::move(first.replay);
  run->progress.poses = first.problem.num_poses();
  run->progress.features = first.problem.num_features();
  run->progress.observations = first.observations;
  first.problem = core::Problem2d();  // in problem.graphslam: 25 B per feature freed
  // The FeatureIndex back from the pass-1 record, for the plan.
  GS_ASSIGN_OR_RETURN(Pass1Record pass1, ReadPass1Record(run->pass1_path));
  GS_CHECK(pass1.observations == first.observations &&
           pass1.counts.size() == static_cast<size_t>(run->progress.features));
  index->Assign(std::move(pass1.counts), std::move(pass1.first_pose), pass1.observations);
  if (!run->native) return Status::Ok();
  run->progress.stage = "spill";
  GS_RETURN_IF_ERROR(WriteIngestProgress(run->env, run->progress_path, run->progress));
  storage::StopPointForTests("ingest_pass1");
  return Status::Ok();
}

// Pass 2: the observations into the buckets of *chunks.
Status PassTwo(const ObservationReplay& replay, int64_t observations, BucketChunkSource* chunks,
               IngestRun* run) {
  if (!run->native) {
    SpillProgress spill;
    return chunks->Spill(InBlocks(replay), &spill, nullptr, 0.0);
  }
  if (run->progress.stage != "spill") return Status::Ok();
  IngestProgress& progress = run->progress;
  const ReplayFrameOptions& replay_options = run->options.replay;
  run->summary->resumed_from_observation = run->resuming ? progress.spill.replay_position : 0;
  run->pass1 = Pass1Record();  // pass 2 replays dense indices: no ids needed
  const ObservationBlockReplay blocks =
      ReplayFrames(run->work, replay_options, progress.spill.replay_position, observations,
                   &run->summary->replay_bytes_read);
  const SpillCheckpoint checkpoint = [&](const SpillProgress& spilled) -> Status {
    progress.spill = spilled;
    GS_RETURN_IF_ERROR(WriteIngestProgress(run->env, run->progress_path, progress));
    // The buckets holding these observations are durable and recorded: the
    // replay before them is needed no more, even by a resume.
    ReleaseReplaySegmentsBefore(run->work, replay_options, spilled.replay_position);
    return Status::Ok();
  };
  GS_RETURN_IF_ERROR(
      chunks->Spill(blocks, &progress.spill, checkpoint, run->options.checkpoint_seconds));
  progress.stage = "chunks";
  progress.chunks_durable = 0;
  GS_RETURN_IF_ERROR(WriteIngestProgress(run->env, run->progress_path, progress));
  const int64_t segment = replay_options.segment_observations();
  ReleaseReplaySegmentsBefore(run->work, replay_options,
                              (observations + segment - 1) / segment * segment);
  return Status::Ok();
}

// Several ranks: each writes its shard of the chunks; rank 0 gathers the
// entries, adds the scans and commits.
Status WriteShardsAndCommit(const BucketChunkSource& chunks, int64_t observations,
                            storage::ChunkStoreWriter* writer, IngestRun* run) {
  const IngestRanks& ranks = run->options.ranks;
  const int64_t num_chunks = chunks.NumChunks();
  const int64_t begin = num_chunks * ranks.rank / ranks.size;
  const int64_t end = num_chunks * (ranks.rank + 1) / ranks.size;
  GS_RETURN_IF_ERROR(writer->WriteChunkShard(chunks, begin, end));
  // before rank 0 commits
  if (!run->root) GS_RETURN_IF_ERROR(run->env->RemoveTree(run->work));
  std::vector<storage::ChunkStoreEntry> entries = writer->entries();
  std::vector<storage::ChunkStoreShard> shards;
  GS_RETURN_IF_ERROR(ranks.gather(&entries, &shards));
  IngestSummary* summary = run->summary;
  summary->chunks = num_chunks;
  summary->observations = observations;
  summary->bucketing = chunks.stats();
  if (!run->root) return Status::Ok();
  writer->SetEntries(std::move(entries), std::move(shards));
  GS_RETURN_IF_ERROR(IngestScans(run->env, run->input, run->store_dir,
                                 run->options.scan_chunk_bytes, false, &summary->scans));
  GS_RETURN_IF_ERROR(writer->Commit());
  static_cast<void>(run->env->RemoveTree(run->work));
  summary->poses = run->progress.poses;
  summary->features = run->progress.features;
  return Status::Ok();
}

// One process: the chunks (from the last durable one on a resume), the
// scans, the manifest.
Status WriteChunksAndCommit(int64_t observations, BucketChunkSource* chunks,
                            storage::ChunkStoreWriter* writer, IngestRun* run) {
  IngestProgress& progress = run->progress;
  int64_t first_chunk = 0;
  if (run->resuming && progress.stage == "chunks") {
    first_chunk = progress.chunks_durable;
    run->summary->resumed_from_chunk = first_chunk;
    GS_RETURN_IF_ERROR(writer->RecoverEntries(first_chunk));
  }
  GS_RETURN_IF_ERROR(writer->WriteChunks(*chunks, first_chunk, [&](int64_t durable) -> Status {
    if (run->native) {
      progress.chunks_durable = durable;
      GS_RETURN_IF_ERROR(WriteIngestProgress(run->env, run->progress_path, progress));
      storage::StopPointAtCountForTests("ingest_chunks", durable);
    }
    chunks->ReleaseBucketsBefore(durable);
    return Status::Ok();
  }));
  IngestSummary* summary = run->summary;
  GS_RETURN_IF_ERROR(IngestScans(run->env, run->input, run->store_dir,
                                 run->options.scan_chunk_bytes, run->resuming, &summary->scans));
  GS_RETURN_IF_ERROR(writer->Commit());
  // scratch only; a leftover is harmless
  static_cast<void>(run->env->RemoveTree(run->work));

  summary->poses = progress.poses;
  summary->features = progress.features;
  summary->observations = observations;
  summary->chunks = chunks->NumChunks();
  summary->bucketing = chunks->stats();
  return Status::Ok();
}

}  // namespace

Status IngestToStore(storage::Env* env, const std::string& input, const std::string& store_dir,
                     const StreamingIngestOptions& options, IngestSummary* summary) {
  GS_CHECK(env != nullptr && summary != nullptr);
  *summary = IngestSummary();
  GS_RETURN_IF_ERROR(options.store.Validate());
  GS_RETURN_IF_ERROR(options.replay.Validate());
  const std::filesystem::path dir(store_dir);
  // Several ranks (IngestRanks): rank 0 does what one process does, except
  // the chunks of other shards; the others plan and write their shard only.
  const IngestRanks& ranks = options.ranks;
  if (ranks.size > 1 && options.resume)
    return Status::NotSupported("ingest --resume with several MPI ranks");
  IngestRun run(env, input, store_dir, options, summary);
  run.root = ranks.rank == 0;
  run.native = options.format == storage::InputFormat::kNative;
  run.work = (dir / (run.root ? std::string(kIngestWorkDirectory)
                              : std::string(kIngestWorkDirectory) + ".rank-" +
                                    std::to_string(ranks.rank)))
                 .string();
  run.progress_path = (std::filesystem::path(run.work) / kIngestProgressName).string();
  run.pass1_path = (std::filesystem::path(run.work) / kPass1RecordName).string();
  ExternalBucketingOptions bucketing;
  bucketing.max_observations_per_chunk = options.max_observations_per_chunk;
  bucketing.buffer_observations = options.buffer_observations;
  bucketing.work_dir = run.work;
  GS_RETURN_IF_ERROR(bucketing.Validate());
  // Never into a folder that is not ours (the commands hold its lock).
  if (run.root) GS_RETURN_IF_ERROR(storage::ClaimStoreDirectory(env, store_dir));
  // The input's identity (size, CRC32C) goes into the manifest, and a resume
  // checks it: a replaced input is ingested afresh even if its mtime is kept.
  // Only a resume needs it before pass 1; a fresh ingest checksums the input
  // in a thread beside pass 1 (a second read of the input, on the core pass
  // 1's serial stages leave idle) and takes it before the first progress
  // record (AwaitInputIdentity).
  storage::ChunkStoreWriteOptions store_options = options.store;
  std::future<StatusOr<storage::FileChecksum>> identity;
  if (options.resume) {
    GS_ASSIGN_OR_RETURN(store_options.input, storage::IdentifyInput(input));
  } else {
    // A missing input is refused now, as before anything is written.
    std::error_code missing;
    if (!std::filesystem::exists(input, missing)) return storage::IdentifyInput(input).status();
    identity = std::async(std::launch::async, [input] { return storage::IdentifyInput(input); });
  }

  // 1. Un-commit before reading anything: a kill from here on leaves a
  // directory without MANIFEST.json, i.e. an incomplete store.
  storage::ChunkStoreWriter writer(env, store_dir, store_options);
  if (run.root) {
    GS_RETURN_IF_ERROR(env->CreateDir(store_dir));
    GS_RETURN_IF_ERROR(writer.Uncommit());
  }
  // The other ranks write into the un-committed store only (STORE/chunks/
  // exists, no stale temporaries left to remove under them).
  if (ranks.size > 1) ranks.barrier();
  GS_RETURN_IF_ERROR(FindResumePoint(store_options, &run));
  run.identity = std::move(identity);

  // 2.-3. Pass 1, the initialization and the problem file.
  FeatureIndex index;
  ObservationReplay replay;
  GS_RETURN_IF_ERROR(PassOne(&writer, &run, &index, &replay));
  summary->streamed = run.native;

  // 4. Pass 2.
  GS_ASSIGN_OR_RETURN(std::unique_ptr<BucketChunkSource> chunks,
                      BucketChunkSource::Plan(index, bucketing));
  const int64_t observations = index.observations();
  index = FeatureIndex();  // the plan has what pass 2 needs: 8 B per feature freed
  // On ranks, each spills only the buckets its shard's chunks are cut from
  // (the shard bounds are WriteShardsAndCommit's).
  if (ranks.size > 1)
    chunks->RestrictSpillToChunks(chunks->NumChunks() * ranks.rank / ranks.size,
                                  chunks->NumChunks() * (ranks.rank + 1) / ranks.size);
  GS_RETURN_IF_ERROR(PassTwo(replay, observations, chunks.get(), &run));
  run.pass1 = Pass1Record();

  // 5. Chunks, then the manifest.
  if (ranks.size > 1) return WriteShardsAndCommit(*chunks, observations, &writer, &run);
  return WriteChunksAndCommit(observations, chunks.get(), &writer, &run);
}

}  // namespace graphslam::partition

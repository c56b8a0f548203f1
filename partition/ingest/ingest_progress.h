// The durable progress of an out-of-core ingest (partition/ingest/streaming_ingest.h),
// so that `graphslam ingest --resume` continues a killed ingest instead of
// restarting it (formats: docs/formats/ingest_progress.md).
//
//   STORE/work/pass1.bin          the first pass's results: pose and feature
//                                 ids (dense order) and the FeatureIndex
//                                 (n_f, p_f per feature). Binary, magic +
//                                 version + CRC32C, written once, atomically.
//   STORE/work/ingest_progress.json  where the ingest stands: the input's
//                                 identity (path, size, CRC32C of the
//                                 contents; not the mtime, which a replaced
//                                 file can keep), the options
//                                 that shape the store, the stage ("spill" or
//                                 "chunks"), the spill's resume point (replay
//                                 position, observations per bucket file) and
//                                 the durable chunk count.
//   STORE/work/replay_NNNNNN.bin  pass 1's observations for pass 2
//                                 (partition/ingest/replay_frames.h), durable before
//                                 the first record.
//                                 Rewritten atomically at every checkpoint.
//
// Every file that a progress record counts is durable before the record is
// (fsync before the rename), so after any kill the record understates, never
// overstates, what is on disk; the resumed ingest truncates or rewrites the
// rest.
//
// THREAD SAFETY: none needed (one ingest per store). ALLOCATION: reading
// pass1.bin keeps the FeatureIndex (8 bytes per feature) and 1 MiB of it.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/status.h"
#include "partition/ingest/external_bucketing.h"
#include "storage/env.h"

namespace graphslam::partition {

inline constexpr const char* kPass1RecordName = "pass1.bin";
inline constexpr const char* kIngestProgressName = "ingest_progress.json";
inline constexpr const char* kIngestProgressFormat = "graphslam-ingest-progress";
// 2: the bucket files are spill frames (partition/ingest/spill_frames.h); 3: pass 2
// replays pass 1's observations from work/replay_NNNNNN.bin
// (partition/ingest/replay_frames.h) and the spill position counts replayed
// observations, not input bytes; 4: the input is identified by its size and
// CRC32C instead of its mtime, and the record carries its own checksum
// (storage/checksummed_json.h). An older record is not resumed: the ingest
// starts afresh.
inline constexpr int kIngestProgressVersion = 4;

struct Pass1Record {
  std::vector<int64_t> pose_ids;
  std::vector<int64_t> feature_ids;
  std::vector<int32_t> counts;      // per feature: n_f
  std::vector<int32_t> first_pose;  // per feature: p_f
  int64_t observations = 0;
};

[[nodiscard]] Status WritePass1Record(storage::Env* env, const std::string& path,
                                      const Pass1Record& record);
// The counts, first poses and observations of a record; its ids are checked
// (CRC) but not kept (a resume needs the FeatureIndex only). Read in blocks
// of 1 MiB: 8 bytes per feature resident. NotFound if `path` is missing;
// Corruption naming the path and what is wrong (magic, version, sizes, CRC).
StatusOr<Pass1Record> ReadPass1Record(const std::string& path);

struct IngestProgress {
  // The input, as it was when the ingest started.
  std::string input;
  int64_t input_bytes = 0;
  uint32_t input_crc32c = 0;  // storage/file_checksum.h IdentifyInput
  // What shapes the store's bytes; a resume with other values starts afresh.
  int64_t chunk_observations = 0;
  int64_t buffer_observations = 0;
  int compression = 0;
  int zstd_level = 0;
  int64_t target_record_bytes = 0;
  std::string source;
  // Observations per replay segment (partition/ingest/replay_frames.h): where the
  // spill position lies in the segments.
  int64_t replay_segment_observations = 0;
  // Counts for the summary.
  int32_t poses = 0;
  int32_t features = 0;
  int64_t observations = 0;
  // "spill": pass 2 resumes at `spill`; "chunks": chunk files
  // [0, chunks_durable) are durable, the rest is rewritten.
  std::string stage;
  SpillProgress spill;
  int64_t chunks_durable = 0;

  // True if `other` describes the same input and options (not the position).
  bool SameIngest(const IngestProgress& other) const;
};

[[nodiscard]] Status WriteIngestProgress(storage::Env* env, const std::string& path,
                                         const IngestProgress& progress);
// NotFound if there is none; Corruption naming the field, or a checksum
// mismatch (an edited record), otherwise.
StatusOr<IngestProgress> ReadIngestProgress(const std::string& path);


}  // namespace graphslam::partition

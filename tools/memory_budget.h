// Memory budgets of the commands that take --memory-limit (graphslam ingest,
// graphslam solve on a store or with --workdir): what a run holds at its
// peak, component by component, and the smallest limit that holds it. A
// limit below that is refused before anything is read, with the needed size
// and its parts in the message; above it the bounded buffers (the ingest's
// observation buffer, the solve's chunks in flight, the CHOLMOD factor of
// `--solver auto`) get what is left.
//
// Ingest of a native log (streamed, partition/ingest/streaming_ingest.h), P poses,
// F observed features, B observations per chunk, K buffered observations:
//   pass 1 = base + blocks + P ingest_pose
//            + max(F read_feature + I feature_id, F held_feature)
//            (while the log is read: the ids, the feature index and the
//            reader's compact lines and flags, reserved to F, so never grown
//            by copying, and its direct id table over the I ids [0, I);
//            after it: the guesses, flags and ids, until problem.graphslam
//            is written, with the index on disk; blocks: tokenizer and
//            replay frames). I is the counts trailer's `feature_ids`; a log
//            without it takes F pass1_feature_unknown_ids instead (the id
//            table up to 8 ids per feature, the arrays grown by doubling)
//   pass 2 = base + blocks + P ingest_pose + F pass2_feature + K buffered_observation
//            (the buffer and the counting sort's scratch of each record)
//   need   = max(pass 1, pass 2 at K = B)
//   K      = (limit - pass 2 at K = 0) / buffered_observation, >= B and at
//            most the observations (a larger buffer would hold nothing more)
// Other formats are read whole by their readers first:
//   read   = base + blocks + input bytes * read_whole_per_input_byte.
// P, F and the observations O of a log are its counts trailer's when it ends
// with one (storage/native_log_counts.h; `graphslam simulate --streaming`
// writes it). Otherwise they are not known before it is read: they are
// estimated from its (decompressed) size at the simulator's proportions
// (~80 bytes per observation line, ~650 bytes of log per observed feature,
// ~30 KB per pose); a log with more features per byte needs more.
//
// Solve of a store (manifest: F, O, the largest chunk; problem file: P and
// its bytes), the peak of reading the problem file and of solving:
//   read      = base + min(reader_blocks, 1.5 problem bytes)
//               + F read_feature + P read_pose    (id map, parsed vectors)
//   streaming = base + P pose_system + F streaming_feature
//               + in_flight * B_max * observation_in_flight + CHOLMOD factor
//   in memory = base + P pose_system + F feature + O observation_in_memory
//               + in_flight * B_max * observation_in_flight + CHOLMOD factor
//   need      = max(read, solve at one chunk in flight)
//   in_flight = clamp((limit - the rest at 0 in flight) / (B_max
//               observation_in_flight), 1, default)
//   sample    = (limit - streaming at one chunk in flight, no factor)
//               / observation_in_memory: the most observations the
//               streaming start's feature sample may hold (it is freed
//               before the passes of the solve)
// and `--solver auto` takes CHOLMOD only if its factor (8 lnz, from the
// symbolic analysis) fits in what the chunks leave; otherwise PCG, whose
// vectors are in pose_system. `--solver cholmod` gets what the chunks leave
// for its factor too: its size is known from CHOLMOD's symbolic analysis,
// which then runs before the first factorization (CheckCholmodFactor); a
// factor that does not fit stops the solve there, naming the smallest limit
// that holds it. In-memory mode is refused with the
// streaming mode's need in the message when only that fits.
//
// The constants were measured with /usr/bin/time -v (peak RSS) on the
// simulator's 10^6, 10^7 and 10^8-feature stores (docs/out_of_core.md,
// "What --memory-limit bounds").
//
// THREAD SAFETY: pure functions, except EstimateIngestInput and
// CountPoseAndFeatureRecords (read files).
#pragma once

#include <cstdint>
#include <string>

#include "core/status.h"
#include "storage/format_detection.h"
#include "storage/native_log_reader.h"

namespace graphslam::tools {

// Process, libraries and TBB's threads, plus the reader's tokenizer blocks
// and replay frames in flight, which fill up to kIngestBlockBytes on inputs
// above ~200 MB (a quarter of the input below that).
inline constexpr int64_t kIngestBaseBytes = int64_t{16} << 20;
inline constexpr int64_t kIngestBlockBytes = int64_t{56} << 20;
inline constexpr int64_t kIngestBytesPerPose = 512;
// Pass 1's per-feature arrays reserved to the counted features
// (docs/out_of_core.md "Memory per feature"). While the log is read: the id
// (8 B), the feature index (8 B), the reader's line (~1.2 B, varints) and
// declared flag (1 bit), ~17 B measured at 10^7 and 20 B counted (the 10^6
// run's other growth), plus the id table's 4 B per id in [0, I). After it
// (the id table freed, the index on disk): the guess, id and flag (25 B) for
// the initialization and problem.graphslam.
inline constexpr int64_t kIngestPass1BytesPerFeature = 20;
inline constexpr int64_t kIngestHeldBytesPerFeature = 26;
inline constexpr int64_t kIngestBytesPerFeatureId = 4;
// Without the id range (or the counts): the id table at up to 8 ids per
// feature and the ids and index at twice their size while they grow.
inline constexpr int64_t kIngestPass1BytesPerFeatureUnknownIds = 72;
// The plan (chunk, slot and chunk lists: 12 B) while it is made from the
// index read back (8 B) and the features' order (4 B, its sort's buffer 2 B).
inline constexpr int64_t kIngestPass2BytesPerFeature = 26;
// Per buffered observation: the buffer and its sort's copy (72 B each), the
// spill frames of one spill or one bucket's file bytes (~19 B at the frames'
// zstd level -1, partition/ingest/spill_frames.h).
inline constexpr int64_t kIngestBytesPerBufferedObservation = 164;
inline constexpr int64_t kReadWholeBytesPerInputByte = 4;
// Native log proportions (uncompressed bytes) and zstd's ratio on it.
inline constexpr int64_t kLogBytesPerObservation = 80;
inline constexpr int64_t kLogBytesPerFeature = 650;
inline constexpr int64_t kLogBytesPerPose = 30000;
inline constexpr int64_t kZstdLogRatioPercent = 350;  // 3.4x measured at level 3

// Process, libraries, TBB's threads (a small solve peaks at ~22 MiB).
inline constexpr int64_t kSolveBaseBytes = int64_t{24} << 20;
// The reduced system (upper triangle of S, ~15 3x3 blocks of 72 B per pose
// plus indices), the PCG vectors and the pose arrays.
inline constexpr int64_t kPoseSystemBytesPerPose = 1450;
inline constexpr int64_t kBytesPerFeature = 64;
// Streaming, per feature: the estimate (16 B), the input's initialized flag
// and the screening's excluded and kept flags (1 B each); the ids are parked
// on disk and no per-feature unknown index is held unless a feature is kept
// (19 B, ~20 B measured at 10^7).
inline constexpr int64_t kBytesPerFeatureStreaming = 24;
inline constexpr int64_t kBytesPerObservationInMemory = 300;
inline constexpr int64_t kBytesPerObservationInFlight = 512;
// Reading problem.graphslam: the tokenizer's blocks in flight (~1.5x a
// small file, at most this), and per feature the estimate, id and flag
// (25 B, reserved to the manifest's count; no id table: the store's
// FEATURE records are unique), per pose its arrays and the pose id map.
inline constexpr int64_t kReaderBlockBytes = int64_t{40} << 20;
inline constexpr int64_t kReadBytesPerFeature = 28;
inline constexpr int64_t kReadBytesPerPose = 256;

// What an ingest will read: counts known or estimated from the input.
struct IngestInput {
  // The fixed part for this input: kIngestBaseBytes + min(kIngestBlockBytes,
  // input_bytes / 4).
  int64_t FixedBytes() const;

  bool streamed = true;       // native log; else read whole
  bool counted = false;       // counts from the log's trailer, not estimated
  int64_t input_bytes = 0;    // decompressed, estimated for zstd
  int64_t poses = 0;
  int64_t features = 0;
  int64_t observations = 0;
  int64_t feature_id_end = -1;  // the trailer's feature_ids; -1: not known

  // Pass 1's per-feature and id-table bytes (the terms above).
  int64_t Pass1FeatureBytes() const;
  // What pass 1 may reserve (counted logs only).
  storage::ExpectedSizes Expected() const;
};

// The sizes above for `path` in `format` (kNative: streamed). IOError if the
// size cannot be read.
StatusOr<IngestInput> EstimateIngestInput(const std::string& path, storage::InputFormat format);

struct IngestBudget {
  int64_t need_bytes = 0;           // the smallest limit that works
  int64_t buffer_observations = 0;  // K
};

// The budget of an ingest under `limit_bytes` (<= 0: no limit, K from 1 GiB
// as a third in 72-byte records, as before). InvalidArgument naming the
// limit, the need and its parts when the limit is below the need.
StatusOr<IngestBudget> BudgetIngest(int64_t limit_bytes, const IngestInput& input,
                                    int64_t chunk_observations);

struct SolveSize {
  int64_t poses = 0;
  int64_t features = 0;
  int64_t observations = 0;
  int64_t chunk_observations = 0;  // the largest chunk
  bool streaming = true;
  int64_t problem_bytes = 0;       // the store's problem file (0: a FILE, read already)
};

struct SolveBudget {
  int64_t need_bytes = 0;       // the smallest limit that works (one chunk in flight)
  int chunks_in_flight = 0;
  int64_t factor_bytes = 0;     // left for a CHOLMOD factor (auto), 0 without a limit
  // Streaming: the most observations the start's feature sample may hold
  // (partition/initialization/sampled_incremental_initialization.h) at
  // observation_in_memory each, in what one chunk in flight leaves; -1
  // without a limit (its own default).
  int64_t sample_observations = -1;
};

// The budget of a solve under `limit_bytes` (<= 0: no limit, default_in_flight).
// InvalidArgument naming the limit, the need and its parts (and, in memory,
// the streaming mode's need) when the limit is below the need.
StatusOr<SolveBudget> BudgetSolve(int64_t limit_bytes, const SolveSize& size,
                                  int default_in_flight);

// CHOLMOD's factor values (8 lnz) come with their indices, the CSC copy of S
// they are made from and CHOLMOD's workspace: this many bytes per value byte.
inline constexpr int64_t kCholmodBytesPerFactorByte = 4;

// `--solver cholmod` under `limit_bytes` (> 0), once the analysis gave the
// factor's `factor_bytes` (8 lnz): OK if kCholmodBytesPerFactorByte times
// that fits in BudgetSolve's factor_bytes; else InvalidArgument naming the
// factor and the smallest limit whose budget holds it (with the chunks in
// flight that limit leaves).
Status CheckCholmodFactor(int64_t limit_bytes, const SolveSize& size, int default_in_flight,
                          double factor_bytes);

// The POSE and FEATURE records of a native log (a store's problem.graphslam,
// which we write: one record per line, the keyword at its start), counted in
// 1 MiB reads without parsing: the poses and features of a store before its
// problem is read. IOError naming the file.
struct RecordCounts {
  int64_t poses = 0;
  int64_t features = 0;
};
StatusOr<RecordCounts> CountPoseAndFeatureRecords(const std::string& path);

// "1.5 GiB", "300 MiB": for the messages.
std::string FormatBytes(int64_t bytes);

// The head of a refusal: "OPTION 1.0 MiB is below the NEED of 2.0 MiB
// (2097152 bytes): the smallest limit that works".
std::string BelowNeed(const std::string& option, int64_t limit_bytes, const std::string& need,
                      int64_t need_bytes);

// The refusal of a CHOLMOD factor of `factor_bytes` values (`factor_need`
// with its indices, S and workspace) under `option` = `limit_bytes`, naming
// `smallest`; `cholmod` / `auto` are how the caller's options spell them.
Status CholmodRefusal(const std::string& option, int64_t limit_bytes, const std::string& cholmod,
                      const std::string& automatic, double factor_bytes, int64_t factor_need,
                      int64_t smallest);

}  // namespace graphslam::tools

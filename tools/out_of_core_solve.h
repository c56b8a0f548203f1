// The out-of-core parts of `graphslam solve` (docs/out_of_core.md):
//
//   --workdir DIR     a FILE input is first ingested into the chunk store DIR
//                     (partition/streaming_ingest.h: bounded memory for native
//                     logs) and solved from there; DIR is kept (checkpoints
//                     land in DIR/checkpoint.json, so --resume works). Without
//                     --workdir a FILE is solved in memory, as before.
//   streaming mode    a chunk store with more than streaming_poses poses or
//                     streaming_observations observations is solved without
//                     loading its observations: the initial guess is the
//                     ingest's Table 1 guess (odometry chaining, features from
//                     first sight; the ingest already checked connectivity with
//                     every observation) instead of the progressive
//                     initialization, whose stages are in-memory sub-problems
//                     (O(poses^2 / 500) work; fine to ~1e5 poses).
//   --memory-limit    bounds the chunks in flight so that an estimate of the
//                     pose system plus chunks in flight fits the budget:
//                       pose system  ~ poses * kPoseSystemBytesPerPose
//                                      + features * (kBytesPerFeature, or
//                                        kBytesPerFeatureStreaming)
//                       one chunk    ~ chunk_observations * kBytesPerObservationInFlight
//                       in flight    = clamp(floor((limit - pose system) / chunk), 1, default)
//                     InvalidArgument when even one chunk does not fit.
//
// THREAD SAFETY: pure functions plus one ingest. ALLOCATION: see the ingest.
#pragma once

#include <cstdint>
#include <string>

#include "core/status.h"

namespace graphslam::tools {

// Bytes per pose of the reduced system (3x3 blocks of S for the pose and its
// band of co-observing neighbours, the PCG vectors, the pose arrays) and per
// feature; bytes an observation costs while its chunk is in flight (the
// record, its Jacobians, the feature's Schur blocks). Calibrated on the 10^7
// and 10^8 streaming solves (docs/out_of_core.md, "Memory per feature"):
// S has ~29 blocks per pose there (both triangles); only the upper triangle
// is stored, (29 - 1) / 2 + 1 = 15 blocks of 72 bytes (~1.07 KB) plus their
// column indices (4 B each) and the transpose index (8 B per off-diagonal
// block), ~1.25 KB; the PCG vectors and the pose arrays add ~0.2 KB. Per
// feature, streaming mode holds the estimate (16), the unknown index (4) and
// flags (3) (heaptrack at 10^7, docs/out_of_core.md "Checkpoint state file
// and the resting memory"), plus a margin for what the problem reader leaves
// on the heap; the candidates of a step (storage/candidate_file.h) and the
// ids (8, storage/feature_id_file.h) are on disk while it solves. In memory
// the ids and the candidates (16) add to that.
inline constexpr int64_t kPoseSystemBytesPerPose = 1450;
inline constexpr int64_t kBytesPerFeature = 64;
inline constexpr int64_t kBytesPerFeatureStreaming = 32;
inline constexpr int64_t kBytesPerObservationInFlight = 512;

// The chunks in flight allowed by `limit_bytes` (<= 0: no limit ->
// default_in_flight); `streaming`: the per-feature cost of streaming mode.
// InvalidArgument naming the budget and the need otherwise.
StatusOr<int> ChunksInFlightForMemoryLimit(int64_t limit_bytes, int64_t poses, int64_t features,
                                           int64_t chunk_observations, int default_in_flight,
                                           bool streaming = false);

// Observation buffer of an ingest under `limit_bytes` (<= 0: 1 GiB): a third
// of the budget in observations (each costs its bytes and as much again in
// the stable sort's scratch), at least `chunk_observations`.
int64_t IngestBufferObservations(int64_t limit_bytes, int64_t chunk_observations);

// True if `workdir` holds a complete chunk store ingested from `input` (the
// manifest's source) whose recorded input identity (size and CRC32C,
// storage/file_checksum.h) is that of `input` now: `solve FILE --workdir DIR
// --resume` then reuses it instead of ingesting again, so the checkpoint in
// DIR matches the store it was made on. An mtime is not trusted: a replaced
// file can keep it. Version 1 stores (no identity) are never current.
bool WorkdirStoreIsCurrent(const std::string& input, const std::string& workdir);

// Ingests `input` (format "auto" or a name) into the store `workdir` with
// `chunk_observations` per chunk; `resume` continues an interrupted ingest
// (partition/streaming_ingest.h). Errors from detection, readers, the ingest.
[[nodiscard]] Status IngestIntoWorkdir(const std::string& input, const std::string& format,
                                       int robot, const std::string& workdir,
                                       int64_t chunk_observations, int64_t memory_limit_bytes,
                                       bool resume = false);

}  // namespace graphslam::tools

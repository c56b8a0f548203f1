// SimulateCampusStreaming: the campus of campus_simulator.h written as the
// robot drives, for data sets whose landmarks and observations do not fit in
// memory (issue 3: 10^8 features on one machine).
//
// Same model as SimulateCampus (grid, street path, pure pursuit, velocity
// motion noise, range-bearing sensing, GPS; campus_simulator.h), with two
// differences that make it stream:
//   - The world is procedural. The landmarks of street segment s (s = 2 (y C +
//     x) + d for the +x (d = 0) / +y (d = 1) segment leaving intersection
//     (x, y) of a C-column grid) are drawn from their own generator, seeded
//     from (seed, s) by SplitMix64, exactly like PlaceLandmarks draws one
//     segment; so any segment is regenerated on demand, identically, and only
//     the segments around the robot are cached. With `features` > 0 the grid is
//     sized as in SimulateCampus and each landmark is kept with probability
//     features / (segments * expected per segment): the count is `features`
//     in expectation (within a few standard deviations), not exactly.
//     Feature id = feature_id_base + (2 s + side) P + slot (side 0 / 1 of
//     the street, slot: the landmark's place along it, P = floor(usable /
//     min_landmark_spacing) + 2 bounds the landmarks per side).
//   - Each run draws from its own generator, seeded from (seed, run), and
//     writes, pose after pose: POSE (with the guess for the run's first pose),
//     FIX (pose 0 without GPS), CONTROL_INFO from the previous pose, the RB
//     observations, GPS. Features are declared by their first use (no FEATURE
//     records; native_log.md allows it), so feature indices follow first
//     sight. The last line is the counts trailer (poses, observed features,
//     observations; storage/native_log_counts.h), in a zstd log a frame of
//     its own.
// A seed therefore gives a different file than SimulateCampus (same
// distribution: landmark density, observations per pose, noise; tested), and
// the same file on every run.
//
// Outputs in `dir`, each written atomically (temp, fsync, rename): log.graphslam,
// ground_truth.tum (true poses), ground_truth_features.csv (id,x,y,observations,
// excluded for every landmark, segment by segment).
//
// THREAD SAFETY: reentrant. ALLOCATION: no state per pose or observation: the cached
// segments around the robot, the planned path (O(distance / block_size)) and
// 2 bytes per landmark slot for the observation counts of the features CSV
// (saturating at 65535); nothing per observation.
#pragma once

#include <cstdint>
#include <string>

#include "core/status.h"
#include "tools/campus_simulator.h"

namespace graphslam::tools {

struct StreamingCampusSummary {
  int grid_columns = 0;
  int grid_rows = 0;
  int64_t poses = 0;
  int64_t landmarks = 0;          // kept landmarks in the world
  int64_t observed_features = 0;  // landmarks seen at least once
  int64_t observations = 0;
  int64_t feature_id_end = 0;     // one past the highest observed feature id
  int64_t motions = 0;
  int64_t gps = 0;
  double distance_travelled = 0;  // m, true path length
};

// Validates `options` (InvalidArgument), simulates and writes the three files
// into `dir` (which must exist). IOError naming the file.
// `zstd_level` > 0: the log is written zstd-compressed at that level, as
// DIR/log.graphslam.zst (storage/compressed_file.h; the readers and the
// ingest decompress it transparently); 0: plain DIR/log.graphslam.
[[nodiscard]] Status SimulateCampusStreaming(const CampusSimulatorOptions& options,
                                             const std::string& dir,
                                             StreamingCampusSummary* summary,
                                             int zstd_level = 0);

}  // namespace graphslam::tools

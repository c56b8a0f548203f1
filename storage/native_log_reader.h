// The graphslam native log (spec: docs/formats/native_log.md, version 1): a
// text log, one record per line, opening with the header "GRAPHSLAM_LOG 1".
//
//   POSE id t [x y theta]          FEATURE id [x y]
//   CONTROL from to v omega dt [a1..a6]        (velocity model, Thrun &
//   CONTROL_INFO from to v omega dt i11..i33    Montemerlo eq. 4)
//   ODOM from to dx dy dth i11 i12 i13 i22 i23 i33
//   RB pose feature range bearing i11 i12 i22   (feature '-': unknown, for --associate)
//   XY pose feature x y i11 i12 i22
//   GPS pose x y i11 i12 i22       FIX pose      # comment
//   RB_POSE from to range bearing i11 i12 i22   (pose `to`'s position seen from
//                                                pose `from`: robot to robot)
//   RB_POSE_INTERP from to to_next alpha range bearing i11 i12 i22
//                  (the position (1 - alpha) p_to + alpha p_to_next seen from
//                   pose `from`, core/interpolated_pose_range_bearing_model.h)
//   SCAN pose file.pcd             (a scan of the pose, path relative to the log)
//
// CONTROL without explicit information gets Omega = R^{-1} with
// R = VelocityMotionCovariance(x_from, u, noise) at the from-pose's guess or
// dead-reckoned prediction (spec rule 3).
//
// ReadNativeLog rejects (Corruption, "<file>:<line>: ...; expected ..."):
// missing header, malformed or non-finite numbers, wrong field counts,
// information not positive definite, undeclared or duplicate poses, duplicate
// or late FEATURE records, dt < 0, range <= 0, self-loops, alpha outside
// [0, 1]. NotSupported: other
// versions, unknown tags. An RB/XY with feature '-' gets a feature of its own
// (id core::kNoFeatureId, core/unidentified_features.h). With `repairs`
// (opt-in), an information given in the file (CONTROL_INFO, ODOM, RB, XY, GPS,
// RB_POSE, RB_POSE_INTERP, the 1-D kinds) that is not positive definite is repaired
// (core/information_repair.h) and counted there instead of rejected; a
// CONTROL's information, computed from the noise model, is not repaired.
//
// WriteNativeLog writes through WriteFileAtomically (atomic_file.h): poses,
// features, FIX, then CONTROL_INFO / ODOM / RB / XY / GPS / RB_POSE(_INTERP) records, numbers as
// "%.17g", so reading the file back gives the same problem (exactly: same
// numbers, same dense order; uninitialized values come back as reader hints).
//
// THREAD SAFETY: reentrant. ALLOCATION: O(records); streamed line by line.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "core/information_repair.h"
#include "core/problem.h"
#include "core/status.h"
#include "storage/env.h"

namespace graphslam::storage {

inline constexpr const char* kNativeLogMagic = "GRAPHSLAM_LOG";
inline constexpr int kNativeLogVersion = 1;

StatusOr<core::Problem2d> ReadNativeLog(const std::string& path,
                                        core::InformationRepairs* repairs = nullptr);

// As ReadNativeLog, but a FEATURE record is checked up to its id and not
// kept: the problem's poses and pose-only factors, with memory O(poses),
// for a log without observations whose features the reader does not need
// (a chunk store's problem on an MPI rank other than 0, docs/distributed.md).
StatusOr<core::Problem2d> ReadNativeLogWithoutFeatures(const std::string& path);

// A SCAN record: the point cloud of pose `pose` (dense index) is in `file`,
// a .pcd path as written in the log (relative to the log's folder unless
// absolute); storage/native_log_scans.h reads them.
struct NativeLogScan {
  int32_t pose = -1;
  std::string file;
  int32_t line = 0;
};

// As ReadNativeLog, and every SCAN record, in file order, into *scans.
StatusOr<core::Problem2d> ReadNativeLog(const std::string& path,
                                        std::vector<NativeLogScan>* scans,
                                        core::InformationRepairs* repairs = nullptr);

// Receives the observations of a streamed read, in file order; an error stops
// the read and is returned by it.
using ObservationSink = std::function<Status(const core::Observation&)>;

// As ReadNativeLog, but every RB / XY record goes to `sink` instead of the
// result (whose `observations` stay empty): memory O(poses + features), so
// the out-of-core ingest (partition/ingest/external_bucketing.h) can read logs whose
// observations do not fit in memory. Same checks, same dense indices.
// `scans`, if given, receives every SCAN record in file order (the ingest
// copies their files into the store, partition/ingest/ingest_scans.h).
// `expected`: the sizes a counts trailer gives before the read
// (storage/native_log_counts.h; 0 / -1: unknown): the per-feature arrays and
// the feature id table are reserved to them, so they never grow by copying
// (a moment with the old and the new array both resident) and keep no spare
// capacity; what the budget of the ingest counts on (tools/memory_budget.h).
// A wrong trailer changes no result, only what is reserved.
struct ExpectedSizes {
  int64_t features = 0;
  int64_t feature_id_end = -1;
  // The caller vouches that every FEATURE id is declared once and that no
  // record refers to a feature (a chunk store's problem file, checked
  // against its manifest's CRC32C, whose sink refuses observations): the
  // reader keeps no id table, lines or flags per feature (4 B per id below
  // the largest, and more, while the file is read).
  bool declared_once = false;
};
//
// The reader's per-feature state (id table, lines, flags) is freed before
// the features' guesses and flags are sized, so they are never resident
// together; until a FEATURE record gives a guess they are not held at all
// (8 B per feature, the id, while the log is read). `size_guesses` false: a
// log without FEATURE guesses comes back with `features` and
// `feature_initialized` empty -- num_features() is 0, feature_ids.size() the
// count -- for the caller to size with SizeGuesses once it has freed memory
// of its own.
StatusOr<core::Problem2d> ReadNativeLogStreaming(const std::string& path,
                                                 const ObservationSink& sink,
                                                 std::vector<NativeLogScan>* scans = nullptr,
                                                 const ExpectedSizes& expected = {},
                                                 bool size_guesses = true);

// Sizes `features` and `feature_initialized` to `feature_ids` (new entries:
// zero, not initialized).
void SizeGuesses(core::Problem2d* problem);

// InvalidArgument (before anything is written) if `problem` is inconsistent;
// IOError if the disk fails (an existing `path` is then left untouched).
// `env` defaults to Env::Default() and must outlive the call.
[[nodiscard]] Status WriteNativeLog(const core::Problem2d& problem, const std::string& path,
                                    Env* env = nullptr);

}  // namespace graphslam::storage

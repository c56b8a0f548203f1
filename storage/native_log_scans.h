// Scans named in a native log (docs/formats/native_log.md, record SCAN):
//
//   SCAN pose file.pcd
//
// The .pcd (PCL's format, any DATA encoding; read by PCL's own loader,
// storage/pcd_io.h ReadPcd) holds the points of pose `pose` in the sensor
// frame, which is the body frame of the pose; its float fields x y z, and
// `intensity` when present. Non-finite points (the NaN holes of organized
// clouds) are dropped. The path is relative to the log's folder unless it is
// absolute. The scan's logged sensor pose is the pose's guess in the log,
// lifted to SE(3): t = (x, y, 0), q = Rz(theta); `graphslam map --poses`
// replaces it by the solved trajectory (row k = pose k, the dense index).
//
// NativeLogScanSource is a map::ScanSource (storage/scan_store.h): one scan
// per chunk, in SCAN record order, each file read on Load. Open() checks that
// every named file exists, so a missing one fails before any fusion;
// a file PCL cannot read, or one without x y z, fails on Load. Errors name
// the log and the SCAN record's line ("run.log:12: SCAN file ...; expected
// ...").
//
// THREAD SAFETY: Load() is const and safe to call concurrently.
// ALLOCATION: the list of records; Load() one scan.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "core/scan.h"
#include "core/se3.h"
#include "core/status.h"
#include "storage/native_log_reader.h"
#include "storage/scan_store.h"

namespace graphslam::map {

class NativeLogScanSource : public ScanSource {
 public:
  // Reads the log (all of ReadNativeLog's checks) and its SCAN records.
  // NotFound naming log:line if a named file does not exist; InvalidArgument
  // if the log names no scan.
  static StatusOr<std::unique_ptr<NativeLogScanSource>> Open(const std::string& log_path);
  // The SCAN records of `log_path` as already read (the ingest's first pass,
  // partition/ingest/ingest_scans.h), each with its scan's logged sensor pose
  // (record_poses[i] for records[i]); the log is not read again. Same checks
  // as Open (every file exists); an empty `records` is allowed.
  static StatusOr<std::unique_ptr<NativeLogScanSource>> FromRecords(
      const std::string& log_path, std::vector<storage::NativeLogScan> records,
      std::vector<core::Pose3> record_poses);

  int64_t NumChunks() const override { return static_cast<int64_t>(records_.size()); }
  Status Load(int64_t index, std::vector<Scan>* scans) const override;

  // The file of SCAN record `index`, resolved against the log's folder.
  const std::string& resolved_path(int64_t index) const {
    return resolved_[static_cast<size_t>(index)];
  }

 private:
  NativeLogScanSource() = default;
  std::string log_name_;  // base name, for messages
  std::vector<storage::NativeLogScan> records_;
  std::vector<std::string> resolved_;
  std::vector<core::Pose3> poses_;  // per record: the logged guess of its pose in SE(3)
};

// A logged planar pose lifted to SE(3): t = (x, y, 0), q = Rz(theta).
core::Pose3 LiftLoggedPose(const core::Pose2& pose);

// Whether `path` is a native log file (its first record is the header).
bool IsNativeLogFile(const std::string& path);

}  // namespace graphslam::map

// The scans of a native log, copied by `graphslam ingest` into the store's
// scan chunks, STORE/scans/ (docs/formats/scan_chunk.md), so that
// `graphslam map STORE/` and a job's map stage read them from the store and
// need neither the log nor its .pcd files again (issue 5: "scans live in
// disk-backed chunks like observations").
//
//   pass 1 (ReadNativeLogStreaming) keeps every SCAN record (pose, file,
//   line) and its scan's logged pose, LoggedScanPoses: the pose's guess as
//   the log gives it, lifted to SE(3), before the initialization -- what
//   `graphslam map LOG` uses, so both give the same map;
//   SaveScanRecords: every named file must exist (NotFound "run.log:12: SCAN
//   file 'a.pcd' (/abs/a.pcd) does not exist ..."), then
//   work/scan_records.bin (atomic), so a resumed ingest needs neither pass 1
//   nor the log's text for its scans;
//   IngestScans, after the observation chunks and before MANIFEST.json: one
//   scan at a time, PCL reads its .pcd (storage/native_log_scans.h; an
//   unreadable one is Corruption naming log:line and the file) and the
//   ScanStoreWriter appends it to the open chunk; each time a chunk file is
//   durable, work/scans_progress.json records the chunks done.
//
// Resume (docs/formats/ingest_progress.md, "Scans"): the scans recorded as
// durable are kept, every other file in STORE/scans/ (a killed run's later
// chunks and temporaries) is removed, and the copy continues with the next
// SCAN record: no scan is lost or written twice, and the folder ends byte
// for byte as an uninterrupted ingest's. A missing or damaged record (or other
// --scan-chunk-size) restarts the scan copy from the first scan.
//
// THREAD SAFETY: one ingest per STORE. ALLOCATION: the SCAN records
// (O(scans)), one scan, one open chunk (scan_chunk_bytes plus one scan).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/problem.h"
#include "core/se3.h"
#include "core/status.h"
#include "storage/env.h"
#include "storage/native_log_reader.h"

namespace graphslam::partition {

inline constexpr const char* kScanRecordsName = "scan_records.bin";
inline constexpr const char* kScanProgressName = "scans_progress.json";

struct ScanIngestSummary {
  int64_t scans = 0;
  int64_t points = 0;
  int64_t chunks = 0;
  int64_t resumed_from_scan = 0;  // scans found durable by a resumed ingest
};

// The logged pose of each record's scan (records[i].pose indexes
// problem.poses, which must not be initialized yet).
std::vector<core::Pose3> LoggedScanPoses(const core::Problem2d& problem,
                                         const std::vector<storage::NativeLogScan>& records);

// Checks that every record's file exists (resolved against the folder of
// `log_path`), then writes `work_dir`/scan_records.bin atomically (no file
// when there are no records).
[[nodiscard]] Status SaveScanRecords(storage::Env* env, const std::string& log_path,
                                     const std::string& work_dir,
                                     const std::vector<storage::NativeLogScan>& records,
                                     const std::vector<core::Pose3>& poses);

// Removes STORE/scans/ (a fresh ingest: no scans of an earlier one survive).
[[nodiscard]] Status RemoveIngestedScans(storage::Env* env, const std::string& store_dir);

// Copies the scans recorded in STORE/work/scan_records.bin into STORE/scans/
// (nothing, and no folder, if there are none or no record file: other input
// formats). `resume`: continue after the durable chunks of
// work/scans_progress.json.
[[nodiscard]] Status IngestScans(storage::Env* env, const std::string& log_path,
                                 const std::string& store_dir, int64_t scan_chunk_bytes,
                                 bool resume, ScanIngestSummary* summary);

}  // namespace graphslam::partition

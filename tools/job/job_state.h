// JobState: the checkpoint of a batch job (OUTPUT/.job/state.json), written
// atomically (storage/atomic_file.h) after every completed stage, so that
// `graphslam run JOB --resume` after a crash or kill -9 skips what is done:
//
//   {"format": "graphslam-job-state", "version": 2,
//    "job_fingerprint": "<FNV-1a 64 of the job file's bytes, hex>",
//    "completed": [{"stage": "ingest", "seconds": 0.8, "peak_rss_bytes": 123}, ...],
//    "files": {"ingested.graphslam": {"bytes": 81234, "crc32c": "1c2d3e4f"}, ...},
//    "state_crc32c": "<CRC32C of this object without this key, dumped compactly>"}
//
// A resume with a job file whose fingerprint differs is refused: its stage
// outputs would belong to another job. "files" lists every file under
// OUTPUT/.job/ (state.json aside) when the last stage completed, with its
// size and CRC32C (storage/crc32c.h); a resume checks them all
// (VerifyJobFiles) and state.json's own checksum, so an edited stage result
// or state file is Corruption naming the file, never a silently different
// output. Version 1 files (no checksums) are refused the same way.
//
// JobLog: the structured log OUTPUT/log.jsonl, one JSON object per line
// ({"time": ISO-8601 UTC, "event": ..., ...}), appended and flushed per line
// (a kill -9 loses at most the line being written; readers skip a torn last
// line).
//
// THREAD SAFETY: JobLog::Write is guarded by a mutex; JobState is a value.
// ALLOCATION: O(stages).
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/status.h"
#include "storage/env.h"

namespace graphslam::tools::job {

inline constexpr const char* kJobStateFormat = "graphslam-job-state";
inline constexpr int kJobStateVersion = 2;

struct CompletedStage {
  std::string stage;
  double seconds = 0.0;
  int64_t peak_rss_bytes = 0;
};

struct FileDigest {
  int64_t bytes = 0;
  uint32_t crc32c = 0;
  bool operator==(const FileDigest&) const = default;
};

struct JobState {
  std::string job_fingerprint;
  std::vector<CompletedStage> completed;
  // Paths relative to the .job folder ('/'-separated) -> their digest.
  std::map<std::string, FileDigest> files;

  bool IsCompleted(const std::string& stage) const;
  const CompletedStage* Find(const std::string& stage) const;
};

// FNV-1a 64-bit of `bytes`, as 16 hex digits.
std::string Fingerprint(const std::string& bytes);

// Digests of every regular file under `work` (recursively), state.json and
// temporary files of atomic writes ("*.tmp-*") aside.
StatusOr<std::map<std::string, FileDigest>> DigestJobFiles(const std::string& work);
// Corruption naming the first file of state.files that is missing or differs.
[[nodiscard]] Status VerifyJobFiles(const std::string& work, const JobState& state);

// Corruption naming the file and field for a malformed state file.
StatusOr<JobState> ReadJobState(const std::string& path);
[[nodiscard]] Status WriteJobState(const std::string& path, const JobState& state);

class JobLog {
 public:
  JobLog() = default;
  JobLog(const JobLog&) = delete;
  JobLog& operator=(const JobLog&) = delete;
  // Opens `path` for appending (created if missing).
  [[nodiscard]] Status Open(const std::string& path);
  // Adds "time" and writes one line; write errors are ignored (logging must
  // not stop a job). A no-op before Open.
  void Write(nlohmann::json event);

 private:
  std::mutex mutex_;
  std::unique_ptr<storage::WritableFile> file_;
};

}  // namespace graphslam::tools::job

// CandidateFile: a core::CandidateStore on disk (core/candidate_store.h), so
// that a streaming solve holds no per-feature array of candidate estimates:
// each step's candidates are appended, one framed record per chunk in chunk
// order (storage/feature_record_file.h, kind 1), and an accepted step reads
// them back sequentially. The file is scratch: rewritten by every step, not
// fsynced (the durable state is the checkpoint), removed by the destructor.
//
// Cost: 20 bytes per observed feature written per recover pass and read once
// per accepted step (sequential I/O, next to the ~60 bytes per observation of
// the chunk reads of the same pass).
//
// THREAD SAFETY: one caller at a time. ALLOCATION: a 1 MiB write buffer.
#pragma once

#include <memory>
#include <string>

#include "core/candidate_store.h"
#include "storage/env.h"

namespace graphslam::storage {

class CandidateFile final : public core::CandidateStore {
 public:
  // `path` is created by Begin() (its directory must exist).
  CandidateFile(Env* env, std::string path) : env_(env), path_(std::move(path)) {}
  ~CandidateFile() override;

  Status Begin() override;
  Status Append(int64_t chunk, const int32_t* features, const core::Point2* values,
                int64_t count) override;
  Status Finish() override;
  // Corruption naming the file and the offset of a damaged record; a missing
  // or unfinished step is InvalidArgument.
  Status ForEach(const std::function<void(int32_t, const core::Point2&)>& visit) override;

  const std::string& path() const { return path_; }

 private:
  Status Spill(bool force);
  Env* env_;
  std::string path_;
  std::unique_ptr<WritableFile> file_;
  std::string buffer_;
  uint64_t records_ = 0;
  uint64_t items_ = 0;
  bool finished_ = false;
};

}  // namespace graphslam::storage

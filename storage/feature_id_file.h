// FeatureIdFile: the feature ids of a streaming solve parked on disk while it
// runs (docs/out_of_core.md, "Checkpoint state file and the resting memory"):
// the solve never reads an id (the passes work on feature indices); only the
// outputs at the end (-o, --features-csv) do. Parking them frees 8 bytes per
// feature for the whole solve (0.35 GB at 4.4*10^7 features), the passes'
// peak included.
//
// The file is scratch, like the candidate file (storage/candidate_file.h):
// derivable from the store, rewritten by every run, not fsynced, removed by
// the destructor. Format: a feature record file of kind 4
// (docs/formats/feature_state.md): records of up to 65536 ids,
// first:i64 count:u32 id:i64[count], in feature order.
//
// THREAD SAFETY: one caller at a time. ALLOCATION: a 1 MiB buffer while
// writing; Restore allocates the ids.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/status.h"
#include "storage/env.h"

namespace graphslam::storage {

class FeatureIdFile {
 public:
  FeatureIdFile(Env* env, std::string path) : env_(env), path_(std::move(path)) {}
  ~FeatureIdFile();
  FeatureIdFile(const FeatureIdFile&) = delete;
  FeatureIdFile& operator=(const FeatureIdFile&) = delete;

  // Writes *ids to the file, then releases their memory (*ids is empty).
  [[nodiscard]] Status Park(std::vector<int64_t>* ids);
  // Reads the ids back into *ids. Corruption naming the file and the offset
  // of a damaged record; NotFound if the file is gone.
  [[nodiscard]] Status Restore(std::vector<int64_t>* ids);

  const std::string& path() const { return path_; }

 private:
  Env* env_;
  std::string path_;
  int64_t count_ = -1;  // ids parked; -1: none
};

}  // namespace graphslam::storage

// The name table of a job map's `run` field. map.pcd stores, per point, the
// index of the run whose scan it came from (a float field, PCL's only
// choice); the runs themselves are named. The table sits beside the cloud:
//
//   map.pcd -> map.runs.json
//   {"pcd": "map.pcd", "field": "run", "runs": ["campus_1", "campus_2", "lab"]}
//
// A point with run = i came from runs[i] (the job's run order, the same
// index in every map of the job, map_cK.pcd included).
//
// THREAD SAFETY: reentrant. ALLOCATION: the table.
#pragma once

#include <string>
#include <vector>

#include "core/status.h"
#include "storage/env.h"

namespace graphslam::storage {

// "DIR/NAME.pcd" -> "DIR/NAME.runs.json" (any other name: NAME + ".runs.json").
std::string PcdRunNamesPath(const std::string& pcd_path);

// Writes the table for `pcd_path` atomically.
[[nodiscard]] Status WritePcdRunNames(const std::string& pcd_path,
                                      const std::vector<std::string>& run_names,
                                      Env* env = nullptr);

// Reads it back; Corruption "<file>: ...; expected ..." when it is not JSON,
// lacks the "runs" list of strings or names another field than "run";
// NotFound when there is no table.
StatusOr<std::vector<std::string>> ReadPcdRunNames(const std::string& pcd_path);

}  // namespace graphslam::storage

// What report.html shows beyond report.json, gathered at the end of the
// export stage from the job's own outputs and the data it already holds:
//   - every run's optimized trajectory, read back from OUTPUT/trajectories/
//     <run>.tum (the very file a user evaluates), and its ground truth;
//   - the landmarks kept and the GPS fixes (for the trajectory figure);
//   - the per-constraint chi2 by type at the optimum (constraint_residuals.h);
//   - the map's .pcd files in OUTPUT (report.json `map.files`).
//
// THREAD SAFETY: reentrant. ALLOCATION: O(problem).
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/status.h"
#include "tools/job/constraint_residuals.h"
#include "tools/job/job_data.h"
#include "tools/trajectory_metrics.h"

namespace graphslam::tools::job {

struct ReportRun {
  std::string name;
  std::vector<StampedPose2> estimated;
  std::vector<StampedPose2> ground_truth;  // empty when unknown
};

struct ReportInputs {
  std::vector<ReportRun> runs;  // job order: run id r of map.pcd is runs[r]
  std::vector<core::Point2> features;
  std::vector<core::Point2> gps;
  std::vector<ConstraintChi2> residuals;
  std::vector<std::string> map_pcds;  // paths
};

// `excluded`: one flag per feature (features the solver dropped). Errors of
// reading a trajectory name its file (ReadTum).
StatusOr<ReportInputs> CollectReportInputs(const JobData& data,
                                           const std::vector<uint8_t>& excluded,
                                           const nlohmann::json& report,
                                           const std::string& output_dir);

}  // namespace graphslam::tools::job

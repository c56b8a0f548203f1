#include "tools/job/report_inputs.h"

#include <filesystem>

#include "storage/env.h"

namespace graphslam::tools::job {

StatusOr<ReportInputs> CollectReportInputs(const JobData& data,
                                           const std::vector<uint8_t>& excluded,
                                           const nlohmann::json& report,
                                           const std::string& output_dir) {
  namespace fs = std::filesystem;
  storage::Env* env = storage::Env::Default();
  ReportInputs inputs;
  for (const RunInfo& run : data.runs) {
    ReportRun r;
    r.name = run.name;
    StatusOr<std::vector<StampedPose2>> estimated =
        ReadTum((fs::path(output_dir) / "trajectories" / (run.name + ".tum")).string());
    if (!estimated.ok()) return estimated.status();
    r.estimated = std::move(estimated).value();
    // The ground truth as exported beside the estimate, on the same clock
    // (a synthetic run's times are shifted to follow the previous run's).
    const fs::path truth_file =
        fs::path(output_dir) / "trajectories" / (run.name + "_groundtruth.tum");
    if (data.ground_truth.contains(run.name) && env->FileExists(truth_file.string())) {
      StatusOr<std::vector<StampedPose2>> truth = ReadTum(truth_file.string());
      if (!truth.ok()) return truth.status();
      r.ground_truth = std::move(truth).value();
    }
    inputs.runs.push_back(std::move(r));
  }
  for (size_t f = 0; f < data.problem.features.size(); ++f)
    if (f >= excluded.size() || !excluded[f]) inputs.features.push_back(data.problem.features[f]);
  for (const core::GpsConstraint& gps : data.problem.gps) inputs.gps.push_back(gps.z);
  inputs.residuals = ConstraintChi2ByType(data.problem, excluded);
  if (report.contains("map"))
    for (const nlohmann::json& file : report["map"].value("files", nlohmann::json::array())) {
      const std::string name = file.get<std::string>();
      if (name.size() > 4 && name.ends_with(".pcd") &&
          env->FileExists((fs::path(output_dir) / name).string()))
        inputs.map_pcds.push_back((fs::path(output_dir) / name).string());
    }
  return inputs;
}

}  // namespace graphslam::tools::job

#include "tools/job/report_inputs.h"

#include <filesystem>

namespace graphslam::tools::job {

StatusOr<ReportInputs> CollectReportInputs(const JobData& data,
                                           const std::vector<uint8_t>& excluded,
                                           const nlohmann::json& report,
                                           const std::string& output_dir) {
  namespace fs = std::filesystem;
  ReportInputs inputs;
  for (const RunInfo& run : data.runs) {
    ReportRun r;
    r.name = run.name;
    StatusOr<std::vector<StampedPose2>> estimated =
        ReadTum((fs::path(output_dir) / "trajectories" / (run.name + ".tum")).string());
    if (!estimated.ok()) return estimated.status();
    r.estimated = std::move(estimated).value();
    if (auto truth = data.ground_truth.find(run.name); truth != data.ground_truth.end())
      r.ground_truth = truth->second;
    inputs.runs.push_back(std::move(r));
  }
  for (size_t f = 0; f < data.problem.features.size(); ++f)
    if (f >= excluded.size() || !excluded[f]) inputs.features.push_back(data.problem.features[f]);
  for (const core::GpsConstraint& gps : data.problem.gps) inputs.gps.push_back(gps.z);
  inputs.residuals = ConstraintChi2ByType(data.problem, excluded);
  if (report.contains("map"))
    for (const nlohmann::json& file : report["map"].value("files", nlohmann::json::array())) {
      const std::string name = file.get<std::string>();
      if (name.size() > 4 && name.ends_with(".pcd") && fs::exists(fs::path(output_dir) / name))
        inputs.map_pcds.push_back((fs::path(output_dir) / name).string());
    }
  return inputs;
}

}  // namespace graphslam::tools::job

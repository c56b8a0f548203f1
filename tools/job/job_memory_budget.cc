#include "tools/job/job_memory_budget.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "tools/memory_budget.h"

namespace graphslam::tools::job {
namespace {

constexpr int64_t kMinBatchPoints = 20'000;
constexpr int64_t kMaxBatchPoints = 2'000'000;

}  // namespace

JobSize JobSizeOf(const JobSpec& job, const core::Problem2d& problem) {
  JobSize size;
  size.poses = problem.num_poses();
  size.features = problem.num_features();
  size.observations = static_cast<int64_t>(problem.observations.size());
  for (const RunSpec& run : job.runs)
    size.map = size.map || !run.scans.empty() || run.simulate_scans.enabled ||
               run.format == "native";  // a native log's SCAN records
  size.map = size.map && job.HasStage(Stage::kMap);
  size.second_problem = job.compare_without_gps;
  for (const RunSpec& run : job.runs) size.associate = size.associate || !run.ids;
  size.associate = size.associate && job.HasStage(Stage::kAssociate);
  return size;
}

StatusOr<JobBudget> BudgetJob(int64_t limit_bytes, const JobSize& size) {
  JobBudget budget;
  const int64_t problems = size.second_problem ? 2 : 1;
  budget.core_bytes = kJobBaseBytes + problems * (size.poses * kJobBytesPerPose +
                                                  size.observations * kJobBytesPerObservation +
                                                  size.features * kJobBytesPerFeature);
  // The map at the smallest batch and tile budget.
  const int64_t map_fixed = budget.core_bytes + kJobMapFixedBytes;
  const int64_t map_need =
      size.map ? map_fixed + kMinBatchPoints * kJobMapBytesPerBatchPoint + kJobMinTileBytes : 0;
  const int64_t associate_need =
      size.associate ? budget.core_bytes + size.features * kJobAssociateBytesPerFeature : 0;
  budget.need_bytes = std::max({budget.core_bytes, map_need, associate_need});
  if (limit_bytes < budget.need_bytes) {
    std::string message =
        BelowNeed("memory_limit", limit_bytes, "job's estimated need", budget.need_bytes) +
        ". Parts: " + FormatBytes(kJobBaseBytes) +
        " fixed + " + FormatBytes(size.poses * kJobBytesPerPose) + " for " +
        std::to_string(size.poses) + " poses + " +
        FormatBytes(size.observations * kJobBytesPerObservation) + " for " +
        std::to_string(size.observations) + " observations + " +
        FormatBytes(size.features * kJobBytesPerFeature) + " for " +
        std::to_string(size.features) + " features, held in memory by every stage" +
        (size.second_problem ? ", twice (compare_without_gps)" : "");
    if (size.associate)
      message += "; data association (ids: false) adds " +
                 FormatBytes(associate_need - budget.core_bytes) + " for the " +
                 std::to_string(size.features) + " features";
    if (size.map)
      message += "; the map stage adds " + FormatBytes(map_need - budget.core_bytes) +
                 " (fusion, one batch of 20000 points, tiles of at least " +
                 FormatBytes(kJobMinTileBytes) + ")";
    return Status::InvalidArgument(message);
  }
  budget.spare_bytes = limit_bytes - budget.core_bytes;
  if (size.map) {
    // limit / 2048 points, as long as the tiles keep their least budget.
    const int64_t room = (limit_bytes - map_fixed - kJobMinTileBytes) / kJobMapBytesPerBatchPoint;
    budget.map_batch_points =
        std::clamp<int64_t>(std::min(limit_bytes / 2048, room), kMinBatchPoints, kMaxBatchPoints);
    budget.map_tile_bytes =
        limit_bytes - map_fixed - budget.map_batch_points * kJobMapBytesPerBatchPoint;
  }
  return budget;
}

Status CheckJobCholmodFactor(int64_t limit_bytes, const JobSize& size, double factor_bytes) {
  GS_ASSIGN_OR_RETURN(const JobBudget budget, BudgetJob(limit_bytes, size));
  const int64_t factor_need =
      static_cast<int64_t>(std::ceil(factor_bytes)) * kCholmodBytesPerFactorByte;
  if (factor_need <= budget.spare_bytes) return Status::Ok();
  const int64_t smallest = std::max(budget.need_bytes, budget.core_bytes + factor_need);
  return CholmodRefusal("memory_limit", limit_bytes, "linear_solver: cholmod",
                        "linear_solver: auto", factor_bytes, factor_need, smallest);
}

}  // namespace graphslam::tools::job

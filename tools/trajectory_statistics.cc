#include "tools/trajectory_statistics.h"

#include <algorithm>
#include <cmath>

#include "core/se2.h"

namespace graphslam::tools {

ErrorStatistics Summarize(std::vector<double> errors) {
  ErrorStatistics s;
  if (errors.empty()) return s;
  const auto n = static_cast<double>(errors.size());
  s.count = static_cast<int64_t>(errors.size());
  double sum = 0, squares = 0;
  for (double e : errors) sum += e, squares += e * e;
  s.mean = sum / n;
  s.rmse = std::sqrt(squares / n);
  s.std = std::sqrt(std::max(0.0, squares / n - s.mean * s.mean));
  std::sort(errors.begin(), errors.end());
  const size_t half = errors.size() / 2;
  s.median = errors.size() % 2 == 1 ? errors[half] : 0.5 * (errors[half - 1] + errors[half]);
  s.max = errors.back();
  return s;
}

AbsoluteErrors AbsolutePositionErrors(const std::vector<StampedPose2>& estimated,
                                      const std::vector<StampedPose2>& ground_truth,
                                      const TrajectoryErrors& matching) {
  AbsoluteErrors out;
  for (size_t k = 0; k < matching.estimated_index.size(); ++k) {
    const StampedPose2& p = estimated[static_cast<size_t>(matching.estimated_index[k])];
    const StampedPose2& q = ground_truth[static_cast<size_t>(matching.ground_truth_index[k])];
    out.stamps.push_back(p.stamp);
    out.position.push_back((matching.alignment * p.pose.head<2>() - q.pose.head<2>()).norm());
  }
  out.statistics = Summarize(out.position);
  return out;
}

RelativeErrors RelativePoseErrors(const std::vector<StampedPose2>& estimated,
                                  const std::vector<StampedPose2>& ground_truth,
                                  const TrajectoryErrors& matching, double delta) {
  RelativeErrors out;
  out.delta = delta;
  const size_t n = matching.estimated_index.size();
  // Distance travelled along the matched ground truth, restarting with every
  // run (a ground-truth index that goes back starts a new run).
  std::vector<double> travelled(n, 0.0);
  std::vector<int> run(n, 0);
  for (size_t k = 1; k < n; ++k) {
    const auto a = static_cast<size_t>(matching.ground_truth_index[k - 1]);
    const auto b = static_cast<size_t>(matching.ground_truth_index[k]);
    const bool new_run = b < a || ground_truth[b].stamp < ground_truth[a].stamp;
    run[k] = run[k - 1] + (new_run ? 1 : 0);
    travelled[k] = new_run ? 0.0
                           : travelled[k - 1] +
                                 (ground_truth[b].pose.head<2>() - ground_truth[a].pose.head<2>()).norm();
  }
  std::vector<double> translation, rotation;
  size_t l = 0;
  for (size_t k = 0; k < n; ++k) {
    l = std::max(l, k + 1);
    while (l < n && run[l] == run[k] && travelled[l] - travelled[k] < delta) ++l;
    if (l >= n || run[l] != run[k]) continue;
    const core::Pose2& pk = estimated[static_cast<size_t>(matching.estimated_index[k])].pose;
    const core::Pose2& pl = estimated[static_cast<size_t>(matching.estimated_index[l])].pose;
    const core::Pose2& qk = ground_truth[static_cast<size_t>(matching.ground_truth_index[k])].pose;
    const core::Pose2& ql = ground_truth[static_cast<size_t>(matching.ground_truth_index[l])].pose;
    const core::Pose2 error = core::Between(core::Between(qk, ql), core::Between(pk, pl));
    translation.push_back(error.head<2>().norm());
    rotation.push_back(std::abs(core::WrapAngle(error.z())));
  }
  out.translation = Summarize(std::move(translation));
  out.rotation = Summarize(std::move(rotation));
  return out;
}

}  // namespace graphslam::tools

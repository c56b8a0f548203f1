#include "partition/association/submap_matching.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <tuple>

#include <Eigen/Core>

namespace graphslam::partition {
namespace {

struct Transform {
  double theta = 0.0;
  core::Point2 t = core::Point2::Zero();
  core::Point2 Apply(const core::Point2& p) const {
    const double c = std::cos(theta), s = std::sin(theta);
    return core::Point2(c * p.x() - s * p.y(), s * p.x() + c * p.y()) + t;
  }
};

struct Scored {
  Transform transform;
  int inliers = 0;
  double sse = 0.0;
  std::vector<std::pair<int32_t, int32_t>> pairs;
};

double WrapAngle(double a) { return std::atan2(std::sin(a), std::cos(a)); }

// Inliers of a transform: closest pairs first, each point used once.
Scored Score(const Transform& transform, const std::vector<core::Point2>& local,
             const std::vector<core::Point2>& map,
             const std::vector<std::vector<int32_t>>& candidates, double tolerance,
             std::vector<uint8_t>* map_used) {
  std::vector<std::tuple<double, int32_t, int32_t>> close;
  const double tol2 = tolerance * tolerance;
  for (size_t k = 0; k < local.size(); ++k) {
    if (candidates[k].empty()) continue;
    const core::Point2 p = transform.Apply(local[k]);
    for (int32_t a : candidates[k]) {
      const double d2 = (p - map[a]).squaredNorm();
      if (d2 <= tol2) close.emplace_back(d2, static_cast<int32_t>(k), a);
    }
  }
  std::sort(close.begin(), close.end());
  Scored scored;
  scored.transform = transform;
  std::vector<uint8_t> local_used(local.size(), 0);
  for (const auto& [d2, k, a] : close) {
    if (local_used[k] || (*map_used)[a]) continue;
    local_used[k] = 1;
    (*map_used)[a] = 1;
    scored.pairs.emplace_back(k, a);
    scored.sse += d2;
  }
  for (const auto& [k, a] : scored.pairs) (*map_used)[a] = 0;
  scored.inliers = static_cast<int>(scored.pairs.size());
  return scored;
}

// Least-squares rigid transform of the pairs (Procrustes in the plane).
Transform Refit(const std::vector<std::pair<int32_t, int32_t>>& pairs,
                const std::vector<core::Point2>& local, const std::vector<core::Point2>& map) {
  core::Point2 cl = core::Point2::Zero(), cm = core::Point2::Zero();
  for (const auto& [k, a] : pairs) {
    cl += local[k];
    cm += map[a];
  }
  cl /= static_cast<double>(pairs.size());
  cm /= static_cast<double>(pairs.size());
  Eigen::Matrix2d s = Eigen::Matrix2d::Zero();
  for (const auto& [k, a] : pairs) s += (local[k] - cl) * (map[a] - cm).transpose();
  Transform transform;
  transform.theta = std::atan2(s(0, 1) - s(1, 0), s(0, 0) + s(1, 1));
  Transform rotation_only;
  rotation_only.theta = transform.theta;
  transform.t = cm - rotation_only.Apply(cl);
  return transform;
}

bool Better(const Scored& a, const Scored& b) {
  return a.inliers != b.inliers ? a.inliers > b.inliers : a.sse < b.sse;
}

}  // namespace

Status SubmapMatchOptions::Validate() const {
  auto positive = [](double v) { return v > 0.0 && std::isfinite(v); };
  if (!positive(search_radius) || !positive(tolerance) || !positive(max_rotation) ||
      !(min_pair_distance >= 0.0) || !std::isfinite(min_pair_distance))
    return Status::InvalidArgument(
        "submap matching: search_radius, tolerance and max_rotation must be finite and > 0, "
        "min_pair_distance finite and >= 0");
  if (min_inliers < 2)
    return Status::InvalidArgument("submap matching: min_inliers must be >= 2, got " +
                                   std::to_string(min_inliers));
  if (ambiguity_margin < 0)
    return Status::InvalidArgument("submap matching: ambiguity_margin must be >= 0, got " +
                                   std::to_string(ambiguity_margin));
  return Status::Ok();
}

SubmapMatch MatchSubmap(const std::vector<core::Point2>& local,
                        const std::vector<core::Point2>& map, const SubmapMatchOptions& options,
                        const std::function<bool(int32_t, int32_t)>& allowed) {
  SubmapMatch result;
  if (static_cast<int>(local.size()) < options.min_inliers ||
      static_cast<int>(map.size()) < options.min_inliers)
    return result;
  // Map candidates of each local point (a transform moves it at most
  // search_radius; an inlier lies within tolerance of where it lands).
  const double reach = options.search_radius + options.tolerance;
  std::vector<std::vector<int32_t>> candidates(local.size());
  for (size_t k = 0; k < local.size(); ++k)
    for (size_t a = 0; a < map.size(); ++a)
      if ((local[k] - map[a]).squaredNorm() <= reach * reach &&
          (!allowed || allowed(static_cast<int32_t>(k), static_cast<int32_t>(a))))
        candidates[k].push_back(static_cast<int32_t>(a));

  std::vector<uint8_t> map_used(map.size(), 0);
  std::vector<Scored> hypotheses;
  const double radius2 = options.search_radius * options.search_radius;
  for (size_t i = 0; i < local.size(); ++i) {
    for (size_t j = i + 1; j < local.size(); ++j) {
      const core::Point2 dl = local[j] - local[i];
      const double length = dl.norm();
      if (length < options.min_pair_distance) continue;
      for (int32_t a : candidates[i]) {
        if ((local[i] - map[a]).squaredNorm() > radius2) continue;
        for (int32_t b : candidates[j]) {
          if (b == a || (local[j] - map[b]).squaredNorm() > radius2) continue;
          const core::Point2 dm = map[b] - map[a];
          if (std::abs(dm.norm() - length) > options.tolerance) continue;
          Transform transform;
          transform.theta =
              WrapAngle(std::atan2(dm.y(), dm.x()) - std::atan2(dl.y(), dl.x()));
          if (std::abs(transform.theta) > options.max_rotation) continue;
          Transform rotation_only;
          rotation_only.theta = transform.theta;
          transform.t = 0.5 * (map[a] + map[b]) - rotation_only.Apply(0.5 * (local[i] + local[j]));
          Scored scored = Score(transform, local, map, candidates, options.tolerance, &map_used);
          if (scored.inliers < 2) continue;
          Scored refit = Score(Refit(scored.pairs, local, map), local, map, candidates,
                               options.tolerance, &map_used);
          if (std::abs(refit.transform.theta) > options.max_rotation) continue;
          hypotheses.push_back(Better(refit, scored) ? std::move(refit) : std::move(scored));
        }
      }
    }
  }
  if (hypotheses.empty()) return result;
  size_t best = 0;
  for (size_t h = 1; h < hypotheses.size(); ++h)
    if (Better(hypotheses[h], hypotheses[best])) best = h;
  const Scored& winner = hypotheses[best];
  // Runner-up: the best hypothesis that moves some inlier of the winner by
  // more than the tolerance (another explanation, e.g. one tree spacing
  // along a row, not a variant of the winner).
  int runner_up = 0;
  std::vector<std::pair<int32_t, int32_t>> winner_pairs = winner.pairs;
  std::sort(winner_pairs.begin(), winner_pairs.end());
  for (const Scored& h : hypotheses) {
    if (h.inliers <= runner_up) continue;
    if (options.distinct_by_pairs) {
      int shared = 0;
      for (const auto& pair : h.pairs)
        shared += std::binary_search(winner_pairs.begin(), winner_pairs.end(), pair) ? 1 : 0;
      if (2 * shared < winner.inliers) runner_up = h.inliers;
      continue;
    }
    for (const auto& [k, a] : winner.pairs)
      if ((h.transform.Apply(local[k]) - winner.transform.Apply(local[k])).norm() >
          options.tolerance) {
        runner_up = h.inliers;
        break;
      }
  }
  result.best_inliers = winner.inliers;
  result.runner_up_inliers = runner_up;
  result.transform = core::Pose2(winner.transform.t.x(), winner.transform.t.y(),
                                 winner.transform.theta);
  result.accepted = winner.inliers >= options.min_inliers &&
                    runner_up <= winner.inliers - options.ambiguity_margin;
  if (result.accepted) {
    result.pairs = winner.pairs;
    std::sort(result.pairs.begin(), result.pairs.end());
  }
  return result;
}

}  // namespace graphslam::partition

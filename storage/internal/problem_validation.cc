#include "storage/internal/problem_validation.h"

#include <algorithm>
#include <string>
#include <unordered_set>
#include <vector>

namespace graphslam::storage::internal {
namespace {

// The distinct values of a list of ids, for the duplicate and collision
// checks: ids >= 0 below 64 x count + 1024 (dense: the readers' and the
// simulator's) as one bit per id of their range, at most 8 B per id and
// usually well under 1 (the simulator's span ~1.7-3.3 ids per feature:
// ~0.2-0.4 B); any others as a sorted copy (8 B per id).
class IdSet {
 public:
  explicit IdSet(const std::vector<int64_t>& ids) {
    int64_t highest = -1;
    bool negative = false;
    for (const int64_t id : ids) {
      negative = negative || id < 0;
      highest = std::max(highest, id);
    }
    dense_ = !negative && highest < 64 * static_cast<int64_t>(ids.size()) + 1024;
    if (dense_) {
      bits_.assign(static_cast<size_t>(highest / 64 + 1), 0);
      for (const int64_t id : ids) {
        uint64_t& word = bits_[static_cast<size_t>(id / 64)];
        const uint64_t bit = uint64_t{1} << (id % 64);
        repeated_ = repeated_ || (word & bit) != 0;
        word |= bit;
      }
    } else {
      sorted_ = ids;
      std::sort(sorted_.begin(), sorted_.end());
      repeated_ = std::adjacent_find(sorted_.begin(), sorted_.end()) != sorted_.end();
    }
  }

  bool repeated() const { return repeated_; }
  bool Contains(int64_t id) const {
    if (!dense_) return std::binary_search(sorted_.begin(), sorted_.end(), id);
    return id >= 0 && id / 64 < static_cast<int64_t>(bits_.size()) &&
           (bits_[static_cast<size_t>(id / 64)] >> (id % 64) & 1) != 0;
  }

 private:
  bool dense_ = false;
  bool repeated_ = false;
  std::vector<uint64_t> bits_;
  std::vector<int64_t> sorted_;
};

Status IndexError(const std::string& element, int64_t value, int64_t limit, const char* what) {
  return Status::InvalidArgument(element + " is " + std::to_string(value) +
                                 "; expected an index in [0, " + std::to_string(limit) + ") (" +
                                 what + ")");
}

Status CheckPose(const std::string& element, int32_t index, const core::Problem2d& problem) {
  if (index < 0 || index >= problem.num_poses()) {
    return IndexError(element, index, problem.num_poses(), "num_poses");
  }
  return Status::Ok();
}

Status CheckFeature(const std::string& element, int32_t index, const core::Problem2d& problem) {
  if (index < 0 || index >= problem.num_features()) {
    return IndexError(element, index, problem.num_features(), "num_features");
  }
  return Status::Ok();
}

template <typename Matrix>
Status CheckFinite(const std::string& element, const Matrix& value) {
  if (!value.allFinite()) {
    return Status::InvalidArgument(element + " has a non-finite entry; expected finite values");
  }
  return Status::Ok();
}

// Every constraint's pose / feature indices and numbers.
Status ValidateConstraintsForWriting(const core::Problem2d& problem) {
  for (size_t k = 0; k < problem.relative_poses.size(); ++k) {
    const auto& c = problem.relative_poses[k];
    const std::string name = "relative_poses[" + std::to_string(k) + "]";
    GS_RETURN_IF_ERROR(CheckPose(name + ".from", c.from, problem));
    GS_RETURN_IF_ERROR(CheckPose(name + ".to", c.to, problem));
    GS_RETURN_IF_ERROR(CheckFinite(name + ".z", c.z));
    GS_RETURN_IF_ERROR(CheckFinite(name + ".information", c.information));
  }
  for (size_t k = 0; k < problem.motions.size(); ++k) {
    const auto& c = problem.motions[k];
    const std::string name = "motions[" + std::to_string(k) + "]";
    GS_RETURN_IF_ERROR(CheckPose(name + ".from", c.from, problem));
    GS_RETURN_IF_ERROR(CheckPose(name + ".to", c.to, problem));
    GS_RETURN_IF_ERROR(CheckFinite(
        name + ".control", Eigen::Vector3d(c.control.v, c.control.omega, c.control.dt)));
    GS_RETURN_IF_ERROR(CheckFinite(name + ".information", c.information));
  }
  for (size_t k = 0; k < problem.gps.size(); ++k) {
    const auto& c = problem.gps[k];
    const std::string name = "gps[" + std::to_string(k) + "]";
    GS_RETURN_IF_ERROR(CheckPose(name + ".pose", c.pose, problem));
    GS_RETURN_IF_ERROR(CheckFinite(name + ".z", c.z));
    GS_RETURN_IF_ERROR(CheckFinite(name + ".information", c.information));
  }
  for (size_t k = 0; k < problem.pose_range_bearings.size(); ++k) {
    const auto& c = problem.pose_range_bearings[k];
    const std::string name = "pose_range_bearings[" + std::to_string(k) + "]";
    GS_RETURN_IF_ERROR(CheckPose(name + ".from", c.from, problem));
    GS_RETURN_IF_ERROR(CheckPose(name + ".to", c.to, problem));
    if (c.interpolated()) {
      GS_RETURN_IF_ERROR(CheckPose(name + ".to_next", c.to_next, problem));
      if (!(c.alpha >= 0.0 && c.alpha <= 1.0))
        return Status::InvalidArgument(name + ".alpha is " + std::to_string(c.alpha) +
                                       "; expected 0 <= alpha <= 1");
    }
    GS_RETURN_IF_ERROR(CheckFinite(name + ".z", c.z));
    GS_RETURN_IF_ERROR(CheckFinite(name + ".information", c.information));
  }
  for (size_t k = 0; k < problem.observations.size(); ++k) {
    const auto& c = problem.observations[k];
    const std::string name = "observations[" + std::to_string(k) + "]";
    GS_RETURN_IF_ERROR(CheckPose(name + ".pose", c.pose, problem));
    GS_RETURN_IF_ERROR(CheckFeature(name + ".feature", c.feature, problem));
    GS_RETURN_IF_ERROR(CheckFinite(name + ".z", c.z));
    GS_RETURN_IF_ERROR(CheckFinite(name + ".information", c.information));
  }
  return Status::Ok();
}

}  // namespace

Status ValidateProblemForWriting(const core::Problem2d& problem, bool shared_id_space) {
  const size_t poses = problem.poses.size();
  if (problem.pose_ids.size() != poses || problem.pose_fixed.size() != poses ||
      problem.pose_initialized.size() != poses || problem.pose_lines.size() != poses ||
      problem.pose_stamps.size() != poses) {
    return Status::InvalidArgument(
        "pose arrays have different sizes; expected poses, pose_ids, pose_fixed, "
        "pose_initialized, pose_lines and pose_stamps of size " + std::to_string(poses));
  }
  const size_t features = problem.features.size();
  if (problem.feature_ids.size() != features || problem.feature_initialized.size() != features) {
    return Status::InvalidArgument(
        "feature arrays have different sizes; expected features, feature_ids and "
        "feature_initialized of size " + std::to_string(features));
  }
  // Duplicate and collision check on IdSets (a bit or 8 bytes per id)
  // instead of hash sets (~40 bytes per id: 1.7 GB at 4.4*10^7 features,
  // while writing the result of a streaming solve). The hash-set loops below
  // run only when there is an error to name, so its message is the one of
  // the first offending index, as before.
  {
    bool clash = false;
    {
      const IdSet feature_set(problem.feature_ids);
      clash = feature_set.repeated();
      if (!clash && shared_id_space) {
        for (const int64_t id : problem.pose_ids) {
          if (feature_set.Contains(id)) {
            clash = true;
            break;
          }
        }
      }
    }
    if (!clash) clash = IdSet(problem.pose_ids).repeated();
    if (!clash) {
      for (size_t i = 0; i < poses; ++i)
        GS_RETURN_IF_ERROR(CheckFinite("poses[" + std::to_string(i) + "]", problem.poses[i]));
      for (size_t i = 0; i < features; ++i)
        GS_RETURN_IF_ERROR(
            CheckFinite("features[" + std::to_string(i) + "]", problem.features[i]));
    }
    if (!clash) return ValidateConstraintsForWriting(problem);
  }
  std::unordered_set<int64_t> pose_ids;
  for (size_t i = 0; i < poses; ++i) {
    if (!pose_ids.insert(problem.pose_ids[i]).second) {
      return Status::InvalidArgument("pose id " + std::to_string(problem.pose_ids[i]) +
                                     " appears twice; expected unique pose ids");
    }
    GS_RETURN_IF_ERROR(CheckFinite("poses[" + std::to_string(i) + "]", problem.poses[i]));
  }
  std::unordered_set<int64_t> feature_ids;
  for (size_t i = 0; i < features; ++i) {
    const int64_t id = problem.feature_ids[i];
    if (!feature_ids.insert(id).second) {
      return Status::InvalidArgument("feature id " + std::to_string(id) +
                                     " appears twice; expected unique feature ids");
    }
    if (shared_id_space && pose_ids.count(id) > 0) {
      return Status::InvalidArgument("feature id " + std::to_string(id) +
                                     " is also a pose id; expected one shared id space "
                                     "without collisions (g2o)");
    }
    GS_RETURN_IF_ERROR(CheckFinite("features[" + std::to_string(i) + "]", problem.features[i]));
  }
  return ValidateConstraintsForWriting(problem);
}

}  // namespace graphslam::storage::internal

#include "core/initialization.h"

#include <cmath>
#include <cstdio>
#include <deque>
#include <numeric>
#include <string>
#include <utility>
#include <vector>

#include "core/observation_models.h"
#include "core/se2.h"
#include "core/velocity_motion_model.h"

namespace graphslam::core {
namespace {

// "source:line: " (or "source: " when the line is unknown).
std::string Location(const Problem2d& problem, int32_t line) {
  // Built by append: GCC 12 gives a false -Wrestrict on `":" + std::string` at -O3.
  std::string location = problem.source.empty() ? std::string("<input>") : problem.source;
  if (line > 0) {
    location.push_back(':');
    location.append(std::to_string(line));
  }
  location.append(": ");
  return location;
}

std::string PoseName(const Problem2d& problem, int32_t pose) {
  return "pose " + std::to_string(problem.pose_ids[pose]);
}

std::string FormatDouble(double value) {
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%.6g", value);
  return buffer;
}

// Finite, symmetric (to 1e-9 relative) and positive definite (LLT succeeds).
// what() names the constraint; messages are built only for an error, not for
// every valid constraint of the file.
template <int kSize, class What>
Status CheckInformation(const Problem2d& problem, const Eigen::Matrix<double, kSize, kSize>& info,
                        int32_t line, const What& what) {
  auto prefix = [&] { return Location(problem, line) + "EDGE information"; };
  if (!info.allFinite())
    return Status::InvalidArgument(prefix() + " is not finite (" + what() + ")");
  const double scale = info.cwiseAbs().maxCoeff();
  const double asymmetry = (info - info.transpose()).cwiseAbs().maxCoeff();
  if (asymmetry > 1e-9 * scale) {
    return Status::InvalidArgument(prefix() + " is not symmetric (" + what() +
                                   "; max |Omega - Omega^T| = " + FormatDouble(asymmetry) + ")");
  }
  // Cholesky by hand (n <= 3), so the failing pivot can be reported.
  Eigen::Matrix<double, kSize, kSize> lower = Eigen::Matrix<double, kSize, kSize>::Zero();
  for (int k = 0; k < kSize; ++k) {
    double pivot = info(k, k);
    for (int j = 0; j < k; ++j) pivot -= lower(k, j) * lower(k, j);
    if (!(pivot > 0.0)) {
      return Status::InvalidArgument(prefix() + " is not positive definite (" + what() +
                                     "; expected all Cholesky pivots > 0, pivot " +
                                     std::to_string(k) + " is " + FormatDouble(pivot) + ")");
    }
    lower(k, k) = std::sqrt(pivot);
    for (int i = k + 1; i < kSize; ++i) {
      double value = info(i, k);
      for (int j = 0; j < k; ++j) value -= lower(i, j) * lower(k, j);
      lower(i, k) = value / lower(k, k);
    }
  }
  return Status::Ok();
}

Status CheckIndex(const Problem2d& problem, int32_t index, int32_t size, int32_t line,
                  const char* constraint, const char* role) {
  if (index < 0 || index >= size) {
    return Status::InvalidArgument(Location(problem, line) + constraint + " refers to " + role +
                                   " index " + std::to_string(index) + ", expected 0.." +
                                   std::to_string(size - 1));
  }
  return Status::Ok();
}

Status CheckConstraints(const Problem2d& problem) {
  const int32_t num_poses = problem.num_poses();
  for (const RelativePoseConstraint& c : problem.relative_poses) {
    GS_RETURN_IF_ERROR(CheckIndex(problem, c.from, num_poses, c.line, "odometry edge", "pose"));
    GS_RETURN_IF_ERROR(CheckIndex(problem, c.to, num_poses, c.line, "odometry edge", "pose"));
    GS_RETURN_IF_ERROR(CheckInformation<3>(problem, c.information, c.line, [&] {
      return "odometry edge " + PoseName(problem, c.from) + " -> " + PoseName(problem, c.to);
    }));
  }
  for (const VelocityMotionConstraint& c : problem.motions) {
    GS_RETURN_IF_ERROR(CheckIndex(problem, c.from, num_poses, c.line, "motion", "pose"));
    GS_RETURN_IF_ERROR(CheckIndex(problem, c.to, num_poses, c.line, "motion", "pose"));
    GS_RETURN_IF_ERROR(CheckInformation<3>(problem, c.information, c.line, [&] {
      return "velocity motion " + PoseName(problem, c.from) + " -> " + PoseName(problem, c.to);
    }));
  }
  for (const GpsConstraint& c : problem.gps) {
    GS_RETURN_IF_ERROR(CheckIndex(problem, c.pose, num_poses, c.line, "GPS fix", "pose"));
    GS_RETURN_IF_ERROR(CheckInformation<2>(
        problem, c.information, c.line, [&] { return "GPS fix of " + PoseName(problem, c.pose); }));
  }
  for (const PoseRangeBearingConstraint& c : problem.pose_range_bearings) {
    GS_RETURN_IF_ERROR(CheckIndex(problem, c.from, num_poses, c.line, "robot sighting", "pose"));
    GS_RETURN_IF_ERROR(CheckIndex(problem, c.to, num_poses, c.line, "robot sighting", "pose"));
    if (c.interpolated())
      GS_RETURN_IF_ERROR(
          CheckIndex(problem, c.to_next, num_poses, c.line, "robot sighting", "pose"));
    GS_RETURN_IF_ERROR(CheckInformation<2>(problem, c.information, c.line, [&] {
      return "robot sighting " + PoseName(problem, c.from) + " -> " + PoseName(problem, c.to);
    }));
  }
  for (const Observation& c : problem.observations)
    GS_RETURN_IF_ERROR(CheckObservation(problem, c));
  return Status::Ok();
}

// Union-find with path halving and union by size.
class DisjointSets {
 public:
  explicit DisjointSets(int32_t size) : parent_(size), size_(size, 1) {
    std::iota(parent_.begin(), parent_.end(), 0);
  }
  int32_t Find(int32_t x) {
    while (parent_[x] != x) {
      parent_[x] = parent_[parent_[x]];
      x = parent_[x];
    }
    return x;
  }
  void Union(int32_t a, int32_t b) {
    a = Find(a);
    b = Find(b);
    if (a == b) return;
    if (size_[a] < size_[b]) std::swap(a, b);
    parent_[b] = a;
    size_[a] += size_[b];
  }

 private:
  std::vector<int32_t> parent_;
  std::vector<int32_t> size_;
};

// The first line (> 0) of a constraint touching `pose`, for poses that were
// implied by an edge and have no line of their own; 0 if none.
int32_t FirstConstraintLine(const Problem2d& problem, int32_t pose) {
  int32_t best = 0;
  auto consider = [&best](int32_t line) {
    if (line > 0 && (best == 0 || line < best)) best = line;
  };
  for (const auto& c : problem.relative_poses)
    if (c.from == pose || c.to == pose) consider(c.line);
  for (const auto& c : problem.motions)
    if (c.from == pose || c.to == pose) consider(c.line);
  for (const auto& c : problem.gps)
    if (c.pose == pose) consider(c.line);
  for (const auto& c : problem.pose_range_bearings)
    if (c.from == pose || c.to == pose) consider(c.line);
  for (const auto& c : problem.observations)
    if (c.pose == pose) consider(c.line);
  return best;
}

Status CheckConnectivity(const Problem2d& problem) {
  const int32_t num_poses = problem.num_poses();
  if (num_poses == 0) return Status::Ok();
  // Nodes 0..num_poses-1 are poses, num_poses + f is feature f.
  DisjointSets sets(num_poses + problem.num_features());
  for (const auto& c : problem.relative_poses) sets.Union(c.from, c.to);
  for (const auto& c : problem.motions) sets.Union(c.from, c.to);
  for (const auto& c : problem.pose_range_bearings) {
    sets.Union(c.from, c.to);
    if (c.interpolated()) sets.Union(c.from, c.to_next);
  }
  for (const auto& c : problem.observations) sets.Union(c.pose, num_poses + c.feature);

  std::vector<int32_t> fixed_poses;
  for (int32_t i = 0; i < num_poses; ++i)
    if (problem.pose_fixed[i] != 0) fixed_poses.push_back(i);
  std::vector<uint8_t> has_gps(num_poses, 0);
  int32_t num_gps_poses = 0;
  for (const auto& c : problem.gps) {
    if (has_gps[c.pose] == 0) ++num_gps_poses;
    has_gps[c.pose] = 1;
  }

  std::vector<uint8_t> anchored_root(num_poses + problem.num_features(), 0);
  // The same gauge as UnknownLayout: fixed poses; else GPS; else pose 0.
  if (fixed_poses.empty() && num_gps_poses == 0) anchored_root[sets.Find(0)] = 1;
  for (int32_t pose : fixed_poses) anchored_root[sets.Find(pose)] = 1;
  for (int32_t i = 0; i < num_poses; ++i)
    if (has_gps[i] != 0) anchored_root[sets.Find(i)] = 1;

  int32_t first_disconnected = -1;
  int32_t num_disconnected = 0;
  for (int32_t i = 0; i < num_poses; ++i) {
    if (anchored_root[sets.Find(i)] != 0) continue;
    if (first_disconnected < 0) first_disconnected = i;
    ++num_disconnected;
  }
  if (first_disconnected < 0) return Status::Ok();

  // Name the anchor(s) the way a user would look them up in the input.
  std::string anchors;
  int32_t num_anchors = num_gps_poses;
  if (fixed_poses.empty() && num_gps_poses == 0) {
    anchors = PoseName(problem, 0);
    ++num_anchors;
  } else if (fixed_poses.empty()) {
    anchors = "GPS";
  } else if (fixed_poses.size() == 1) {
    anchors = PoseName(problem, fixed_poses[0]);
    ++num_anchors;
  } else {
    anchors = std::to_string(fixed_poses.size()) + " fixed poses";
    num_anchors += static_cast<int32_t>(fixed_poses.size());
  }
  if (num_gps_poses > 0) {
    if (anchors == "GPS") anchors.clear(); else anchors += ", ";
    anchors += std::to_string(num_gps_poses) +
               (num_gps_poses == 1 ? " pose with a GPS fix" : " poses with a GPS fix");
  }
  int32_t line = problem.pose_lines[first_disconnected];
  if (line <= 0) line = FirstConstraintLine(problem, first_disconnected);
  std::string message = Location(problem, line) + PoseName(problem, first_disconnected) +
                        " is not connected to " +
                        (num_anchors == 1 ? "the anchor (" : "an anchor (") + anchors +
                        ") by any constraint; expected an odometry edge or a shared landmark";
  if (num_disconnected > 1) {
    message += " (" + std::to_string(num_disconnected - 1) + " more poses are disconnected)";
  }
  return Status::InvalidArgument(message);
}

// One incident edge of a pose, for the chaining search.
struct Incidence {
  enum class Kind : uint8_t { kRelativePose, kMotion } kind;
  int32_t index;
};

// The guess of a pose no chain reaches: its GPS fix (theta = 0), else the
// nearest lower-index pose that has a guess, else the origin.
Pose2 SeedGuess(const Problem2d& problem, const std::vector<uint8_t>& has_guess, int32_t pose) {
  for (const GpsConstraint& c : problem.gps) {
    if (c.pose == pose) return Pose2(c.z.x(), c.z.y(), 0.0);
  }
  for (int32_t i = pose - 1; i >= 0; --i) {
    if (has_guess[i] != 0) return problem.poses[i];
  }
  return Pose2::Zero();
}

void InitializePoses(Problem2d* problem) {
  const int32_t num_poses = problem->num_poses();
  if (num_poses == 0) return;
  std::vector<std::vector<Incidence>> incidences(num_poses);
  for (int32_t k = 0; k < static_cast<int32_t>(problem->relative_poses.size()); ++k) {
    const auto& c = problem->relative_poses[k];
    incidences[c.from].push_back({Incidence::Kind::kRelativePose, k});
    incidences[c.to].push_back({Incidence::Kind::kRelativePose, k});
  }
  for (int32_t k = 0; k < static_cast<int32_t>(problem->motions.size()); ++k) {
    const auto& c = problem->motions[k];
    incidences[c.from].push_back({Incidence::Kind::kMotion, k});
    incidences[c.to].push_back({Incidence::Kind::kMotion, k});
  }

  std::vector<uint8_t> has_guess = problem->pose_initialized;
  std::deque<int32_t> queue;
  for (int32_t i = 0; i < num_poses; ++i)
    if (has_guess[i] != 0) queue.push_back(i);
  if (queue.empty()) {
    // Table 1 l.2: mu_0 = 0 (or pose 0's GPS fix, so the guess is in the map frame).
    problem->poses[0] = SeedGuess(*problem, has_guess, 0);
    has_guess[0] = 1;
    queue.push_back(0);
  }

  int32_t next_unreached = 0;
  for (;;) {
    while (!queue.empty()) {
      const int32_t pose = queue.front();
      queue.pop_front();
      for (const Incidence& incidence : incidences[pose]) {
        int32_t other = -1;
        Pose2 guess;
        if (incidence.kind == Incidence::Kind::kRelativePose) {
          const auto& c = problem->relative_poses[incidence.index];
          if (c.from == pose) {
            other = c.to;
            guess = Compose(problem->poses[pose], c.z);
          } else {
            other = c.from;
            guess = Compose(problem->poses[pose], Inverse(c.z));
          }
        } else {
          const auto& c = problem->motions[incidence.index];
          if (c.from == pose) {
            other = c.to;
            guess = PredictVelocityMotion(problem->poses[pose], c.control);
          } else {
            other = c.from;
            guess = InverseVelocityMotion(problem->poses[pose], c.control);
          }
        }
        if (has_guess[other] != 0) continue;
        problem->poses[other] = guess;
        has_guess[other] = 1;
        queue.push_back(other);
      }
    }
    // Poses tied to the rest only through features: start a new chain.
    while (next_unreached < num_poses && has_guess[next_unreached] != 0) ++next_unreached;
    if (next_unreached == num_poses) break;
    problem->poses[next_unreached] = SeedGuess(*problem, has_guess, next_unreached);
    has_guess[next_unreached] = 1;
    queue.push_back(next_unreached);
  }
  for (int32_t i = 0; i < num_poses; ++i) problem->pose_initialized[i] = 1;
}

void InitializeFeatures(Problem2d* problem) {
  for (const Observation& observation : problem->observations) PlaceFeature(problem, observation);
}

}  // namespace

Status CheckObservation(const Problem2d& problem, const Observation& c) {
  GS_RETURN_IF_ERROR(
      CheckIndex(problem, c.pose, problem.num_poses(), c.line, "observation", "pose"));
  GS_RETURN_IF_ERROR(
      CheckIndex(problem, c.feature, problem.num_features(), c.line, "observation", "feature"));
  return CheckInformation<2>(problem, c.information, c.line, [&] {
    return "observation of feature " + std::to_string(problem.feature_ids[c.feature]) + " from " +
           PoseName(problem, c.pose);
  });
}

void PlaceFeature(Problem2d* problem, const Observation& observation) {
  uint8_t& initialized = problem->feature_initialized[observation.feature];
  if (initialized != 0) return;
  const Pose2& pose = problem->poses[observation.pose];
  problem->features[observation.feature] =
      InvertObservation(observation.kind, pose, observation.z);
  initialized = 1;
}

Status ValidateProblem(const Problem2d& problem) {
  const size_t num_poses = problem.poses.size();
  GS_CHECK(problem.pose_ids.size() == num_poses && problem.pose_fixed.size() == num_poses &&
           problem.pose_initialized.size() == num_poses && problem.pose_lines.size() == num_poses);
  const size_t num_features = problem.features.size();
  GS_CHECK(problem.feature_ids.size() == num_features &&
           problem.feature_initialized.size() == num_features);
  GS_RETURN_IF_ERROR(CheckConstraints(problem));
  return CheckConnectivity(problem);
}

Status InitializeProblem(Problem2d* problem) {
  GS_CHECK(problem != nullptr);
  GS_RETURN_IF_ERROR(ValidateProblem(*problem));
  InitializePoses(problem);
  InitializeFeatures(problem);
  return Status::Ok();
}

}  // namespace graphslam::core

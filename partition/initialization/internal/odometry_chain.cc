#include "partition/initialization/internal/odometry_chain.h"

#include <utility>

#include "core/se2.h"
#include "core/velocity_motion_model.h"

namespace graphslam::partition::internal {
namespace {

// The pose `p` predicted through `edge` from the placed pose edge.other.
core::Pose2 Chain(const core::Problem2d& problem, const std::vector<core::Pose2>& poses,
                  const PoseEdge& edge) {
  const core::Pose2& from = poses[edge.other];
  if (edge.motion) {
    const core::VelocityControl& u = problem.motions[edge.constraint].control;
    return edge.incoming ? core::PredictVelocityMotion(from, u)
                         : core::InverseVelocityMotion(from, u);
  }
  const core::Pose2& z = problem.relative_poses[edge.constraint].z;
  return edge.incoming ? core::Compose(from, z) : core::Compose(from, core::Inverse(z));
}

}  // namespace

std::vector<std::vector<PoseEdge>> OdometryAdjacency(const core::Problem2d& problem) {
  std::vector<std::vector<PoseEdge>> adjacency(problem.poses.size());
  for (size_t k = 0; k < problem.relative_poses.size(); ++k) {
    const core::RelativePoseConstraint& c = problem.relative_poses[k];
    if (c.from == c.to) continue;
    adjacency[c.to].push_back({c.from, static_cast<int32_t>(k), false, true});
    adjacency[c.from].push_back({c.to, static_cast<int32_t>(k), false, false});
  }
  for (size_t k = 0; k < problem.motions.size(); ++k) {
    const core::VelocityMotionConstraint& c = problem.motions[k];
    if (c.from == c.to) continue;
    adjacency[c.to].push_back({c.from, static_cast<int32_t>(k), true, true});
    adjacency[c.from].push_back({c.to, static_cast<int32_t>(k), true, false});
  }
  return adjacency;
}

void PlacePoses(const core::Problem2d& problem, const std::vector<std::vector<PoseEdge>>& adjacency,
                int32_t begin, int32_t end, std::vector<core::Pose2>* poses,
                std::vector<uint8_t>* placed) {
  std::vector<int32_t> pending;
  for (int32_t p = begin; p < end; ++p)
    if (!(*placed)[p]) pending.push_back(p);
  while (!pending.empty()) {
    // Increasing index, so a pose's odometry predecessor is placed first; more
    // passes only for poses reached backwards (edges to a later pose).
    bool progress = true;
    while (progress && !pending.empty()) {
      progress = false;
      std::vector<int32_t> still_pending;
      for (int32_t p : pending) {
        const PoseEdge* best = nullptr;
        for (const PoseEdge& edge : adjacency[p]) {
          if (edge.other >= end || !(*placed)[edge.other]) continue;
          if (best == nullptr || edge.other > best->other) best = &edge;
        }
        if (best == nullptr) {
          still_pending.push_back(p);
          continue;
        }
        (*poses)[p] = Chain(problem, *poses, *best);
        (*placed)[p] = 1;
        progress = true;
      }
      pending = std::move(still_pending);
    }
    if (pending.empty()) break;
    // The lowest pose no odometry reaches from a placed pose starts another
    // odometry chain (the first pose of a later run): nothing ties it to the
    // poses placed so far, so it keeps its input guess, which is in the frame
    // of the stage solutions (their gauge is the input's: pose 0 or the fixed
    // poses held at their input values, or GPS). An offset from the input
    // guess of an earlier pose would carry that pose's dead-reckoning drift
    // over to an unrelated chain (a 10 000-pose run: tens of metres and a
    // rotation, which left the full solve stuck far from its optimum).
    // The poses after it then chain from it.
    const int32_t start = pending.front();
    (*poses)[start] = problem.poses[start];
    (*placed)[start] = 1;
    pending.erase(pending.begin());
  }
}

}  // namespace graphslam::partition::internal

#include "core/initialization_3d.h"

#include <Eigen/Cholesky>
#include <deque>
#include <numeric>
#include <string>
#include <vector>

namespace graphslam::core {
namespace {

std::string Where(const Problem3d& problem, int32_t line) {
  std::string name = problem.source;
  const size_t slash = name.find_last_of('/');
  if (slash != std::string::npos) name = name.substr(slash + 1);
  if (name.empty()) name = "<problem>";
  return line > 0 ? name + ":" + std::to_string(line) : name;
}

template <typename Matrix>
bool IsValidInformation(const Matrix& m) {
  if (!m.allFinite()) return false;
  if (!((m - m.transpose()).cwiseAbs().maxCoeff() <= 1e-9 * (1.0 + m.cwiseAbs().maxCoeff())))
    return false;
  Eigen::LLT<Matrix> llt(m);
  return llt.info() == Eigen::Success;
}

int32_t Find(std::vector<int32_t>& parent, int32_t a) {
  while (parent[a] != a) a = parent[a] = parent[parent[a]];
  return a;
}

bool IsIdentity(const Pose3& p) {
  return p.t.norm() <= 1e-12 && std::abs(std::abs(p.q.w()) - 1.0) <= 1e-12;
}

}  // namespace

Status ValidateProblem3d(const Problem3d& problem) {
  const int32_t n = problem.num_poses();
  const int32_t m = problem.num_features();
  auto pose_ok = [n](int32_t p) { return p >= 0 && p < n; };
  for (const RelativePose3Constraint& c : problem.relative_poses) {
    if (!pose_ok(c.from) || !pose_ok(c.to))
      return Status::InvalidArgument(Where(problem, c.line) + ": relative pose " +
                                     std::to_string(c.from) + " -> " + std::to_string(c.to) +
                                     " is out of range; expected poses in [0, " +
                                     std::to_string(n) + ")");
    if (!IsValidInformation(c.information))
      return Status::InvalidArgument(Where(problem, c.line) +
                                     ": information matrix is not symmetric positive definite; "
                                     "expected a valid 6x6 information matrix");
  }
  for (const Point3Observation& o : problem.observations) {
    if (!pose_ok(o.pose) || o.feature < 0 || o.feature >= m)
      return Status::InvalidArgument(Where(problem, o.line) +
                                     ": observation index out of range; expected a known pose "
                                     "and feature");
    if (!IsValidInformation(o.information))
      return Status::InvalidArgument(Where(problem, o.line) +
                                     ": information matrix is not symmetric positive definite; "
                                     "expected a valid 3x3 information matrix");
  }
  for (const Gps3Constraint& g : problem.gps) {
    if (!pose_ok(g.pose))
      return Status::InvalidArgument(Where(problem, g.line) +
                                     ": GPS pose out of range; expected a known pose");
    if (!IsValidInformation(g.information))
      return Status::InvalidArgument(Where(problem, g.line) +
                                     ": information matrix is not symmetric positive definite; "
                                     "expected a valid 3x3 information matrix");
  }
  // Connectivity to an anchor (union-find over poses; features join poses).
  if (n == 0) return Status::Ok();
  std::vector<int32_t> parent(n + m);
  std::iota(parent.begin(), parent.end(), 0);
  auto unite = [&parent](int32_t a, int32_t b) { parent[Find(parent, a)] = Find(parent, b); };
  for (const RelativePose3Constraint& c : problem.relative_poses) unite(c.from, c.to);
  for (const Point3Observation& o : problem.observations) unite(o.pose, n + o.feature);
  std::vector<uint8_t> anchored_root(n + m, 0);
  bool any_fixed = false;
  for (int32_t p = 0; p < n; ++p) any_fixed = any_fixed || problem.pose_fixed[p] != 0;
  for (int32_t p = 0; p < n; ++p)
    if (problem.pose_fixed[p]) anchored_root[Find(parent, p)] = 1;
  if (!any_fixed) anchored_root[Find(parent, 0)] = 1;
  for (const Gps3Constraint& g : problem.gps) anchored_root[Find(parent, g.pose)] = 1;
  for (int32_t p = 0; p < n; ++p) {
    if (!anchored_root[Find(parent, p)]) {
      return Status::InvalidArgument(
          Where(problem, problem.pose_lines[p]) + ": pose " + std::to_string(problem.pose_ids[p]) +
          " is not connected to the anchor by any constraint; expected a relative-pose edge, a "
          "shared landmark or a GPS fix");
    }
  }
  return Status::Ok();
}

Status InitializeProblem3d(Problem3d* problem) {
  GS_RETURN_IF_ERROR(ValidateProblem3d(*problem));
  const int32_t n = problem->num_poses();
  if (n == 0) return Status::Ok();
  // A file whose guesses are all the identity carries no guess.
  bool all_identity = true;
  for (int32_t p = 0; p < n && all_identity; ++p)
    all_identity = IsIdentity(problem->poses[p]) || !problem->pose_initialized[p];
  bool some_edge_moves = false;
  for (const RelativePose3Constraint& c : problem->relative_poses)
    some_edge_moves = some_edge_moves || !IsIdentity(c.z);
  std::vector<uint8_t> known(problem->pose_initialized.begin(), problem->pose_initialized.end());
  if (all_identity && some_edge_moves) std::fill(known.begin(), known.end(), 0);
  std::deque<int32_t> queue;
  for (int32_t p = 0; p < n; ++p)
    if (known[p]) queue.push_back(p);
  if (queue.empty()) {
    // Seed: a fixed pose if any (keeping its guess), else pose 0 at identity.
    int32_t seed = 0;
    for (int32_t p = 0; p < n; ++p)
      if (problem->pose_fixed[p]) {
        seed = p;
        break;
      }
    if (!problem->pose_fixed[seed]) problem->poses[seed] = Pose3::Identity();
    known[seed] = 1;
    queue.push_back(seed);
  }
  std::vector<std::vector<int32_t>> edges_of(n);
  for (size_t k = 0; k < problem->relative_poses.size(); ++k) {
    edges_of[problem->relative_poses[k].from].push_back(static_cast<int32_t>(k));
    edges_of[problem->relative_poses[k].to].push_back(static_cast<int32_t>(k));
  }
  while (!queue.empty()) {
    const int32_t p = queue.front();
    queue.pop_front();
    for (int32_t k : edges_of[p]) {
      const RelativePose3Constraint& c = problem->relative_poses[k];
      if (c.from == p && !known[c.to]) {
        problem->poses[c.to] = Compose(problem->poses[p], c.z);
        known[c.to] = 1;
        queue.push_back(c.to);
      } else if (c.to == p && !known[c.from]) {
        problem->poses[c.from] = Compose(problem->poses[p], Inverse(c.z));
        known[c.from] = 1;
        queue.push_back(c.from);
      }
    }
  }
  for (const Gps3Constraint& g : problem->gps) {
    if (!known[g.pose]) {
      problem->poses[g.pose] = Pose3::Identity();
      problem->poses[g.pose].t = g.z;
      known[g.pose] = 1;
    }
  }
  for (int32_t p = 0; p < n; ++p) {
    if (!known[p]) problem->poses[p] = Pose3::Identity();
    problem->pose_initialized[p] = 1;
  }
  for (const Point3Observation& o : problem->observations) {
    if (!problem->feature_initialized[o.feature]) {
      problem->features[o.feature] = TransformPoint(problem->poses[o.pose], o.z);
      problem->feature_initialized[o.feature] = 1;
    }
  }
  return Status::Ok();
}

}  // namespace graphslam::core

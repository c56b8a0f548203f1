#include "partition/association/joint_compatibility.h"

#include <Eigen/Cholesky>
#include <limits>

#include "partition/association/internal/chi_square.h"

namespace graphslam::partition {
namespace {

constexpr double kInfinity = std::numeric_limits<double>::infinity();

// D^2 of the pairs (observation[k], target[k]).
double PairsMahalanobisSquared(const ScanAssociationInput& input,
                               const std::vector<int32_t>& observations,
                               const std::vector<int32_t>& targets) {
  const int k = static_cast<int>(observations.size());
  if (k == 0) return 0.0;
  const int n = input.observations;
  Eigen::VectorXd mean(2 * k);
  Eigen::MatrixXd covariance(2 * k, 2 * k);
  for (int a = 0; a < k; ++a) {
    const int oa = 2 * observations[a], ta = 2 * (n + targets[a]);
    mean.segment<2>(2 * a) = input.means[observations[a]] - input.means[n + targets[a]];
    for (int b = 0; b <= a; ++b) {
      const int ob = 2 * observations[b], tb = 2 * (n + targets[b]);
      const Eigen::Matrix2d block =
          input.covariance.block<2, 2>(oa, ob) - input.covariance.block<2, 2>(oa, tb) -
          input.covariance.block<2, 2>(ta, ob) + input.covariance.block<2, 2>(ta, tb);
      covariance.block<2, 2>(2 * a, 2 * b) = block;
      covariance.block<2, 2>(2 * b, 2 * a) = block.transpose();
    }
  }
  const Eigen::LLT<Eigen::MatrixXd> llt(covariance);
  if (llt.info() != Eigen::Success) return kInfinity;
  const double d2 = mean.dot(llt.solve(mean));
  return std::isfinite(d2) ? d2 : kInfinity;
}

class Search {
 public:
  Search(const ScanAssociationInput& input, const JointCompatibilityOptions& options)
      : input_(input), options_(options), used_(input.targets, 0) {
    const int n = input.observations;
    // The quantile is an iterative inverse (microseconds): once per pairing
    // count, not once per search node.
    gates_.resize(n + 1);
    for (int k = 1; k <= n; ++k)
      gates_[k] = internal::ChiSquareQuantile(2.0 * static_cast<double>(k), options.z);
    compatible_.resize(n);
    for (int i = 0; i < n; ++i) {
      for (int a = 0; a < input.targets; ++a) {
        if (PairsMahalanobisSquared(input, {i}, {a}) <= gates_[1]) compatible_[i].push_back(a);
      }
    }
    best_.target.assign(n, -1);
    best_.pairings = 0;
    best_.mahalanobis_squared = 0.0;
    current_.assign(n, -1);
  }

  ScanAssignment Run() {
    Visit(0, 0.0);
    best_.nodes = nodes_;
    best_.exhausted = nodes_ >= options_.max_nodes;
    return best_;
  }

 private:
  void Visit(int i, double d2) {
    ++nodes_;
    const int n = input_.observations;
    if (i == n) {
      const int pairings = static_cast<int>(observations_.size());
      if (pairings > best_.pairings ||
          (pairings == best_.pairings && d2 < best_.mahalanobis_squared)) {
        best_.target = current_;
        best_.pairings = pairings;
        best_.mahalanobis_squared = d2;
      }
      return;
    }
    if (nodes_ >= options_.max_nodes) return;
    const int pairings = static_cast<int>(observations_.size());
    // Pair observation i: every pairing left still possible.
    if (CanBeat(pairings + (n - i), d2)) {
      const double gate = gates_[pairings + 1];
      for (int a : compatible_[i]) {
        if (used_[a]) continue;
        observations_.push_back(i);
        targets_.push_back(a);
        const double extended = PairsMahalanobisSquared(input_, observations_, targets_);
        if (extended <= gate && CanBeat(pairings + (n - i), extended)) {
          used_[a] = 1;
          current_[i] = a;
          Visit(i + 1, extended);
          current_[i] = -1;
          used_[a] = 0;
        }
        observations_.pop_back();
        targets_.pop_back();
      }
    }
    // Leave observation i unpaired (a new feature).
    if (CanBeat(pairings + (n - i - 1), d2)) Visit(i + 1, d2);
  }

  // Could a hypothesis with at most `reachable` pairings and D^2 >= d2 be
  // preferred to the best so far?
  bool CanBeat(int reachable, double d2) const {
    if (reachable != best_.pairings) return reachable > best_.pairings;
    return d2 < best_.mahalanobis_squared;
  }

  const ScanAssociationInput& input_;
  const JointCompatibilityOptions& options_;
  std::vector<double> gates_;  // [k]: the joint gate of k pairings (2k dof)
  std::vector<std::vector<int32_t>> compatible_;
  std::vector<uint8_t> used_;
  std::vector<int32_t> observations_, targets_, current_;
  ScanAssignment best_;
  int64_t nodes_ = 0;
};

}  // namespace

double JointMahalanobisSquared(const ScanAssociationInput& input,
                               const std::vector<int32_t>& target) {
  std::vector<int32_t> observations, targets;
  for (size_t i = 0; i < target.size(); ++i) {
    if (target[i] < 0) continue;
    observations.push_back(static_cast<int32_t>(i));
    targets.push_back(target[i]);
  }
  return PairsMahalanobisSquared(input, observations, targets);
}

ScanAssignment AssignScanJointly(const ScanAssociationInput& input,
                                 const JointCompatibilityOptions& options) {
  return Search(input, options).Run();
}

}  // namespace graphslam::partition

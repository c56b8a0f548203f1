#include "partition/initialization/feature_localization.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <tuple>
#include <utility>

#include "core/angle.h"
#include "core/observation_models.h"

namespace graphslam::partition {
namespace {

using core::ObservationKind;
using core::Point2;
using core::Pose2;

bool PlacesAPoint(ObservationKind kind) {
  return kind == ObservationKind::kRangeBearing || kind == ObservationKind::kPointXY;
}

// Observation chi2 of the used observations at `pose`; infinite when a model
// is degenerate there (a feature on the pose).
double Chi2(std::span<const core::Observation> observations, const std::vector<int32_t>& used,
            const std::vector<Point2>& features, const Pose2& pose) {
  double chi2 = 0.0;
  for (int32_t k : used) {
    const core::Observation& o = observations[k];
    Eigen::Vector2d e;
    if (!core::EvaluateObservation(o.kind, pose, features[o.feature], o.z, &e, nullptr, nullptr))
      return HUGE_VAL;
    chi2 += e.dot(o.information * e);
  }
  return chi2;
}

// The pose's information H = sum_i J_i^T W_i J_i from the used observations
// at `pose`; false when a model is degenerate there.
bool Information(std::span<const core::Observation> observations, const std::vector<int32_t>& used,
                 const std::vector<Point2>& features, const Pose2& pose, Eigen::Matrix3d* h,
                 Eigen::Vector3d* b) {
  h->setZero();
  b->setZero();
  for (int32_t k : used) {
    const core::Observation& o = observations[k];
    Eigen::Vector2d e;
    Eigen::Matrix<double, 2, 3> j;
    if (!core::EvaluateObservation(o.kind, pose, features[o.feature], o.z, &e, &j, nullptr))
      return false;
    *h += j.transpose() * o.information * j;
    *b += j.transpose() * o.information * e;
  }
  return true;
}

// Marginal standard deviations (heading, position) of a pose with
// information h; infinite when h is not positive definite.
std::pair<double, double> MarginalSigmas(const Eigen::Matrix3d& h) {
  const Eigen::LDLT<Eigen::Matrix3d> ldlt(h);
  if (ldlt.info() != Eigen::Success || !ldlt.isPositive() || ldlt.vectorD().minCoeff() <= 0.0)
    return {HUGE_VAL, HUGE_VAL};
  const Eigen::Matrix3d covariance = ldlt.solve(Eigen::Matrix3d::Identity());
  if (!covariance.allFinite()) return {HUGE_VAL, HUGE_VAL};
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> position(covariance.topLeftCorner<2, 2>());
  return {std::sqrt(std::max(0.0, covariance(2, 2))),
          std::sqrt(std::max(0.0, position.eigenvalues().maxCoeff()))};
}

}  // namespace

Pose2 AlignPoints2d(const std::vector<Point2>& local, const std::vector<Point2>& global) {
  Point2 local_mean = Point2::Zero(), global_mean = Point2::Zero();
  for (size_t i = 0; i < local.size(); ++i) {
    local_mean += local[i];
    global_mean += global[i];
  }
  const double n = static_cast<double>(local.size());
  local_mean /= n;
  global_mean /= n;
  double dot = 0.0, cross = 0.0;
  for (size_t i = 0; i < local.size(); ++i) {
    const Point2 l = local[i] - local_mean, g = global[i] - global_mean;
    dot += l.dot(g);
    cross += l.x() * g.y() - l.y() * g.x();
  }
  const double theta = (dot == 0.0 && cross == 0.0) ? 0.0 : std::atan2(cross, dot);
  const Eigen::Rotation2Dd rotation(theta);
  const Point2 t = global_mean - rotation * local_mean;
  return Pose2(t.x(), t.y(), theta);
}

FeatureLocalization LocalizeFromFeatures(const FeatureLocalizationOptions& options,
                                         std::span<const core::Observation> observations,
                                         const std::vector<Point2>& features,
                                         const std::vector<uint8_t>& placed, const Pose2& guess,
                                         Pose2* pose) {
  FeatureLocalization result;
  *pose = guess;
  std::vector<int32_t> used;
  std::vector<Point2> local, global;
  const Pose2 origin = Pose2::Zero();
  for (int32_t k = 0; k < static_cast<int32_t>(observations.size()); ++k) {
    const core::Observation& o = observations[k];
    if (placed[o.feature] < options.placed_at_least || placed[o.feature] == 0 ||
        !PlacesAPoint(o.kind))
      continue;
    used.push_back(k);
    local.push_back(core::InvertObservation(o.kind, origin, o.z));
    global.push_back(features[o.feature]);
  }
  // Distinct features: a feature observed twice from one pose counts once.
  std::vector<int32_t> distinct;
  for (int32_t k : used) distinct.push_back(observations[k].feature);
  std::sort(distinct.begin(), distinct.end());
  result.features =
      static_cast<int>(std::unique(distinct.begin(), distinct.end()) - distinct.begin());
  if (result.features < options.min_features) return result;
  result.localized = true;

  result.guess_chi2 = Chi2(observations, used, features, guess);
  const Pose2 aligned = AlignPoints2d(local, global);
  const double aligned_chi2 = Chi2(observations, used, features, aligned);
  result.closed_form_chosen = aligned_chi2 < result.guess_chi2;
  Pose2 x = result.closed_form_chosen ? aligned : guess;
  double chi2 = std::min(aligned_chi2, result.guess_chi2);
  for (int iteration = 0; iteration < options.max_iterations && std::isfinite(chi2); ++iteration) {
    Eigen::Matrix3d h;
    Eigen::Vector3d b;
    if (!Information(observations, used, features, x, &h, &b)) break;
    const Eigen::LDLT<Eigen::Matrix3d> ldlt(h);
    if (ldlt.info() != Eigen::Success) break;
    const Eigen::Vector3d step = ldlt.solve(-b);
    if (!step.allFinite()) break;
    Pose2 next = x + step;
    next.z() = core::WrapAngle(next.z());
    const double next_chi2 = Chi2(observations, used, features, next);
    if (!(next_chi2 < chi2)) break;
    const bool small = chi2 - next_chi2 < 1e-9 * chi2;
    x = next;
    chi2 = next_chi2;
    if (small) break;
  }
  result.chi2 = chi2;
  Eigen::Matrix3d h;
  Eigen::Vector3d b;
  std::tie(result.heading_sigma, result.position_sigma) =
      Information(observations, used, features, x, &h, &b) ? MarginalSigmas(h)
                                                      : std::pair(HUGE_VAL, HUGE_VAL);
  if (!(chi2 <= options.max_chi2_per_observation * static_cast<double>(used.size())) ||
      !(result.heading_sigma <= options.max_heading_sigma) ||
      !(result.position_sigma <= options.max_position_sigma)) {
    // The placed features disagree, or do not pin the pose: keep the guess.
    result.localized = false;
    result.closed_form_chosen = false;
    return result;
  }
  *pose = x;
  return result;
}

}  // namespace graphslam::partition

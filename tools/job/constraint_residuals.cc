#include "tools/job/constraint_residuals.h"

#include <cmath>

#include "core/gps_model.h"
#include "core/interpolated_pose_range_bearing_model.h"
#include "core/point_observation_model.h"
#include "core/pose_range_bearing_model.h"
#include "core/range_bearing_model.h"
#include "core/relative_pose_model.h"
#include "core/velocity_motion_model.h"

namespace graphslam::tools::job {

std::vector<ConstraintChi2> ConstraintChi2ByType(const core::Problem2d& problem,
                                                 const std::vector<uint8_t>& excluded_features) {
  const auto& poses = problem.poses;
  ConstraintChi2 odometry{"odometry (relative pose)", 3, {}};
  for (const core::RelativePoseConstraint& c : problem.relative_poses) {
    Eigen::Vector3d e;
    Eigen::Matrix3d a, b;
    core::EvaluateRelativePose(poses[static_cast<size_t>(c.from)], poses[static_cast<size_t>(c.to)],
                               c.z, &e, &a, &b);
    odometry.chi2.push_back(e.dot(c.information * e));
  }
  ConstraintChi2 motion{"velocity motion", 3, {}};
  for (const core::VelocityMotionConstraint& c : problem.motions) {
    Eigen::Vector3d e;
    core::EvaluateVelocityMotion(poses[static_cast<size_t>(c.from)],
                                 poses[static_cast<size_t>(c.to)], c.control, &e, nullptr, nullptr);
    motion.chi2.push_back(e.dot(c.information * e));
  }
  ConstraintChi2 landmarks{"landmark observation", 2, {}};
  for (const core::Observation& o : problem.observations) {
    const auto f = static_cast<size_t>(o.feature);
    if (f < excluded_features.size() && excluded_features[f]) continue;
    Eigen::Vector2d e;
    Eigen::Matrix<double, 2, 3> jp;
    Eigen::Matrix2d jf;
    const core::Pose2& pose = poses[static_cast<size_t>(o.pose)];
    if (o.kind == core::ObservationKind::kPointXY) {
      core::EvaluatePointObservation(pose, problem.features[f], o.z, &e, &jp, &jf);
    } else if (!core::EvaluateRangeBearing(pose, problem.features[f], o.z, &e, &jp, &jf)) {
      continue;
    }
    landmarks.chi2.push_back(e.dot(o.information * e));
  }
  ConstraintChi2 gps{"GPS", 2, {}};
  for (const core::GpsConstraint& c : problem.gps) {
    Eigen::Vector2d e;
    Eigen::Matrix<double, 2, 3> j;
    core::EvaluateGps(poses[static_cast<size_t>(c.pose)], c.z, &e, &j);
    gps.chi2.push_back(e.dot(c.information * e));
  }
  ConstraintChi2 sightings{"robot sighting (range-bearing)", 2, {}};
  for (const core::PoseRangeBearingConstraint& c : problem.pose_range_bearings) {
    Eigen::Vector2d e;
    Eigen::Matrix<double, 2, 3> a, b;
    const bool ok =
        c.interpolated()
            ? core::EvaluateInterpolatedPoseRangeBearing(
                  poses[static_cast<size_t>(c.from)], poses[static_cast<size_t>(c.to)],
                  poses[static_cast<size_t>(c.to_next)], c.alpha, c.z, &e, nullptr, nullptr,
                  nullptr)
            : core::EvaluatePoseRangeBearing(poses[static_cast<size_t>(c.from)],
                                             poses[static_cast<size_t>(c.to)], c.z, &e, &a, &b);
    if (!ok) continue;
    sightings.chi2.push_back(e.dot(c.information * e));
  }
  std::vector<ConstraintChi2> out;
  for (ConstraintChi2* type : {&odometry, &motion, &landmarks, &gps, &sightings})
    if (!type->chi2.empty()) out.push_back(std::move(*type));
  return out;
}

double Chi2Density(double s, int k) {
  if (s < 0 || k <= 0) return 0.0;
  const double half = 0.5 * k;
  if (s == 0) return k == 2 ? 0.5 : (k == 1 ? INFINITY : 0.0);
  return std::exp((half - 1) * std::log(s) - 0.5 * s - half * std::log(2.0) - std::lgamma(half));
}

}  // namespace graphslam::tools::job

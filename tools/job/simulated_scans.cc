#include "tools/job/simulated_scans.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>

namespace graphslam::tools::job {
namespace {

double Uniform(std::mt19937_64& rng) {  // [0, 1)
  return static_cast<double>(rng() >> 11) * 0x1.0p-53;
}
double Normal(std::mt19937_64& rng) {  // Box-Muller
  const double u1 = 1.0 - Uniform(rng), u2 = Uniform(rng);
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * std::numbers::pi * u2);
}

}  // namespace

map::Campus3d MakeCampusWorld3d(const CampusSimulatorOptions& options,
                                const SimulatedCampus& campus, double sensor_height) {
  map::Campus3dOptions o;
  o.columns = std::max(1, campus.grid_columns - 1);
  o.rows = std::max(1, campus.grid_rows - 1);
  o.block_size = options.block_size;
  // Facades kBuildingSetback behind the landmarks, but always a block left.
  o.street_width = std::min(options.street_width + 2.0 * kBuildingSetback, 0.9 * options.block_size);
  o.min_height = 6.0;
  o.max_height = 15.0;
  o.slope_x = 0.0;
  o.slope_y = 0.0;
  o.crown_radius = kCrownRadius;
  o.sensor_height = sensor_height > 0 ? sensor_height : 1e-3;
  o.seed = options.seed;
  map::Campus3d world = map::MakeCampus3d(o);
  world.trees.clear();
  for (const core::Point2& landmark : campus.true_features) world.trees.push_back({landmark});
  return world;
}

core::Pose3 LiftPose(const core::Pose2& pose, double height) {
  core::Pose3 lifted;
  lifted.q = Eigen::Quaterniond(Eigen::AngleAxisd(pose.z(), Eigen::Vector3d::UnitZ()));
  lifted.t = Eigen::Vector3d(pose.x(), pose.y(), height);
  return lifted;
}

Status SimulateCampusScans(const map::Campus3d& world, const std::vector<core::Pose2>& true_poses,
                           const std::vector<int32_t>& run_of_pose, int64_t first_pose,
                           int32_t first_run, const SimulatedScanSpec& spec, double sensor_height,
                           uint64_t seed, const std::function<Status(map::Scan&&)>& sink) {
  if (spec.beams < 1) return Status::InvalidArgument("scan_beams must be >= 1");
  if (!(spec.max_range > 0)) return Status::InvalidArgument("scan_max_range must be > 0");
  std::mt19937_64 rng(seed ^ 0x5ca115ULL);
  for (size_t k = 0; k < true_poses.size(); ++k) {
    map::Scan scan;
    scan.pose = first_pose + static_cast<int64_t>(k);
    scan.run = first_run + (k < run_of_pose.size() ? run_of_pose[k] : 0);
    scan.sensor_pose = LiftPose(true_poses[k], sensor_height);
    const Eigen::Matrix3d r = scan.sensor_pose.rotation();
    const std::vector<int> nearby = world.NearbyTrees(scan.sensor_pose.t, spec.max_range);
    for (int beam = 0; beam < spec.beams; ++beam) {
      const double angle = 2.0 * std::numbers::pi * (beam + 0.5) / spec.beams;
      const Eigen::Vector3d local(0.0, std::cos(angle), std::sin(angle));
      const double t = world.Cast(scan.sensor_pose.t, r * local, spec.max_range, &nearby);
      if (!std::isfinite(t)) continue;
      const double noisy = t + spec.range_sigma * Normal(rng);
      scan.points.push_back((noisy * local).cast<float>());
    }
    GS_RETURN_IF_ERROR(sink(std::move(scan)));
  }
  return Status::Ok();
}

}  // namespace graphslam::tools::job

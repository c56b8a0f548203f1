#include "tools/campus_simulator.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>
#include <string>
#include <utility>

#include "core/angle.h"
#include "core/check.h"
#include "core/range_bearing_model.h"
#include "tools/internal/campus_world.h"

namespace graphslam::tools {
namespace {

using internal::DirectionAngle;
using internal::DirectionVector;
using internal::ExpectedLandmarksPerSegment;
using internal::Grid;
using internal::Grow;
using internal::kStepX;
using internal::kStepY;
using internal::Random;
using internal::StreetPath;

// Landmarks along both sides of every street segment, in segment order.
std::vector<core::Point2> PlaceLandmarks(const Grid& grid, const CampusSimulatorOptions& options,
                                         Random* random) {
  std::vector<core::Point2> landmarks;
  const double half_width = 0.5 * options.street_width;
  const double begin = half_width;
  const double end = options.block_size - half_width;
  auto place_side = [&](const core::Point2& origin, const core::Point2& along,
                        const core::Point2& offset) {
    double t = begin + random->Uniform(0.0, 0.5 * options.min_landmark_spacing);
    while (t <= end) {
      landmarks.push_back(origin + t * along + offset);
      t += random->Uniform(options.min_landmark_spacing, options.max_landmark_spacing);
    }
  };
  for (int y = 0; y < grid.rows; ++y) {
    for (int x = 0; x < grid.columns; ++x) {
      for (int direction = 0; direction < 2; ++direction) {  // +x and +y segments
        if (!grid.Contains(x + kStepX[direction], y + kStepY[direction])) continue;
        const core::Point2 along = DirectionVector(direction);
        const core::Point2 normal = DirectionVector(direction + 1);
        place_side(grid.Node(x, y), along, half_width * normal);
        place_side(grid.Node(x, y), along, -half_width * normal);
      }
    }
  }
  return landmarks;
}

// Sizes the grid and places the landmarks (exactly options.features when > 0).
std::vector<core::Point2> BuildCampus(const CampusSimulatorOptions& options, Random* random,
                                      Grid* grid) {
  grid->columns = 3;
  grid->rows = 3;
  grid->block_size = options.block_size;
  if (options.features == 0) {
    // Street length about a quarter of the driving distance: every street is
    // driven several times over.
    const double distance = static_cast<double>(options.poses) * options.speed * options.dt;
    while (static_cast<double>(grid->Segments()) * options.block_size < 0.25 * distance) Grow(grid);
    return PlaceLandmarks(*grid, options, random);
  }
  const double per_segment = ExpectedLandmarksPerSegment(options);
  while (static_cast<double>(grid->Segments()) * per_segment <
         1.05 * static_cast<double>(options.features)) {
    Grow(grid);
  }
  std::vector<core::Point2> landmarks = PlaceLandmarks(*grid, options, random);
  while (static_cast<int64_t>(landmarks.size()) < options.features) {
    Grow(grid);
    landmarks = PlaceLandmarks(*grid, options, random);
  }
  // Drop a random subset (partial Fisher-Yates), keeping the segment order.
  const int64_t count = static_cast<int64_t>(landmarks.size());
  std::vector<int64_t> order(static_cast<size_t>(count));
  for (int64_t i = 0; i < count; ++i) order[static_cast<size_t>(i)] = i;
  const int64_t drop = count - options.features;
  for (int64_t i = 0; i < drop; ++i) {
    const int64_t j = i + random->UniformInt(count - i);
    std::swap(order[static_cast<size_t>(i)], order[static_cast<size_t>(j)]);
  }
  std::vector<uint8_t> dropped(static_cast<size_t>(count), 0);
  for (int64_t i = 0; i < drop; ++i) dropped[static_cast<size_t>(order[static_cast<size_t>(i)])] = 1;
  std::vector<core::Point2> kept;
  kept.reserve(static_cast<size_t>(options.features));
  for (int64_t i = 0; i < count; ++i) {
    if (!dropped[static_cast<size_t>(i)]) kept.push_back(landmarks[static_cast<size_t>(i)]);
  }
  return kept;
}

// Landmarks bucketed in square cells of side sensor_range.
class LandmarkIndex {
 public:
  LandmarkIndex(const std::vector<core::Point2>& landmarks, const Grid& grid, double cell_size,
                double margin)
      : landmarks_(landmarks), cell_size_(cell_size) {
    origin_ = core::Point2(-margin, -margin);
    columns_ = static_cast<int>(((grid.columns - 1) * grid.block_size + 2 * margin) / cell_size) + 1;
    rows_ = static_cast<int>(((grid.rows - 1) * grid.block_size + 2 * margin) / cell_size) + 1;
    cells_.resize(static_cast<size_t>(columns_) * static_cast<size_t>(rows_));
    for (size_t i = 0; i < landmarks.size(); ++i) {
      cells_[CellOf(landmarks[i])].push_back(static_cast<int32_t>(i));
    }
  }

  // Appends the indices of the landmarks within `radius` of `center`, in increasing order.
  void Near(const core::Point2& center, double radius, std::vector<int32_t>* out) const {
    out->clear();
    const int x0 = ClampColumn((center.x() - radius - origin_.x()) / cell_size_);
    const int x1 = ClampColumn((center.x() + radius - origin_.x()) / cell_size_);
    const int y0 = ClampRow((center.y() - radius - origin_.y()) / cell_size_);
    const int y1 = ClampRow((center.y() + radius - origin_.y()) / cell_size_);
    for (int y = y0; y <= y1; ++y) {
      for (int x = x0; x <= x1; ++x) {
        for (int32_t index : cells_[static_cast<size_t>(y) * columns_ + x]) {
          if ((landmarks_[static_cast<size_t>(index)] - center).squaredNorm() <= radius * radius) {
            out->push_back(index);
          }
        }
      }
    }
    std::sort(out->begin(), out->end());
  }

 private:
  int ClampColumn(double value) const {
    return static_cast<int>(std::clamp(std::floor(value), 0.0, static_cast<double>(columns_ - 1)));
  }
  int ClampRow(double value) const {
    return static_cast<int>(std::clamp(std::floor(value), 0.0, static_cast<double>(rows_ - 1)));
  }
  size_t CellOf(const core::Point2& p) const {
    const int x = ClampColumn((p.x() - origin_.x()) / cell_size_);
    const int y = ClampRow((p.y() - origin_.y()) / cell_size_);
    return static_cast<size_t>(y) * columns_ + x;
  }

  const std::vector<core::Point2>& landmarks_;  // must outlive the index
  double cell_size_;
  core::Point2 origin_;
  int columns_ = 0;
  int rows_ = 0;
  std::vector<std::vector<int32_t>> cells_;
};

Status Positive(const char* name, double value) {
  if (!(value > 0.0) || !std::isfinite(value)) {
    return Status::InvalidArgument(std::string(name) + " must be a finite number > 0, got " +
                                   std::to_string(value));
  }
  return Status::Ok();
}

Status NonNegative(const char* name, double value) {
  if (!(value >= 0.0) || !std::isfinite(value)) {
    return Status::InvalidArgument(std::string(name) + " must be a finite number >= 0, got " +
                                   std::to_string(value));
  }
  return Status::Ok();
}

Eigen::Matrix3d SymmetricInverse(const Eigen::Matrix3d& covariance) {
  const Eigen::Matrix3d inverse = covariance.inverse();
  return 0.5 * (inverse + inverse.transpose());
}

}  // namespace

Status CampusSimulatorOptions::Validate() const {
  if (runs < 1) return Status::InvalidArgument("runs must be >= 1, got " + std::to_string(runs));
  if (poses < 2 * static_cast<int64_t>(runs)) {
    return Status::InvalidArgument("poses must be >= 2 per run (" + std::to_string(2 * runs) +
                                   " for " + std::to_string(runs) + " runs), got " +
                                   std::to_string(poses));
  }
  if (features < 0) {
    return Status::InvalidArgument("features must be >= 0 (0: from the campus size), got " +
                                   std::to_string(features));
  }
  if (gps_every < 0) {
    return Status::InvalidArgument("gps_every must be >= 0 (0: no GPS), got " +
                                   std::to_string(gps_every));
  }
  if (feature_id_base < poses) {
    return Status::InvalidArgument("feature_id_base (" + std::to_string(feature_id_base) +
                                   ") must be >= poses (" + std::to_string(poses) +
                                   ") so that pose and feature ids never collide");
  }
  GS_RETURN_IF_ERROR(Positive("block_size", block_size));
  GS_RETURN_IF_ERROR(Positive("street_width", street_width));
  if (street_width >= block_size) {
    return Status::InvalidArgument("street_width (" + std::to_string(street_width) +
                                   ") must be < block_size (" + std::to_string(block_size) + ")");
  }
  GS_RETURN_IF_ERROR(Positive("min_landmark_spacing", min_landmark_spacing));
  GS_RETURN_IF_ERROR(Positive("max_landmark_spacing", max_landmark_spacing));
  if (max_landmark_spacing < min_landmark_spacing) {
    return Status::InvalidArgument("max_landmark_spacing (" + std::to_string(max_landmark_spacing) +
                                   ") must be >= min_landmark_spacing (" +
                                   std::to_string(min_landmark_spacing) + ")");
  }
  GS_RETURN_IF_ERROR(NonNegative("turn_radius", turn_radius));
  const double radius = turn_radius > 0 ? turn_radius : 0.5 * street_width;
  if (radius > 0.5 * block_size) {
    return Status::InvalidArgument("turn radius (" + std::to_string(radius) +
                                   ") must be <= block_size / 2 (" +
                                   std::to_string(0.5 * block_size) + ")");
  }
  if (!(straight_probability >= 0.0 && straight_probability <= 1.0)) {
    return Status::InvalidArgument("straight_probability must be in [0, 1], got " +
                                   std::to_string(straight_probability));
  }
  GS_RETURN_IF_ERROR(Positive("lookahead", lookahead));
  GS_RETURN_IF_ERROR(Positive("max_omega", max_omega));
  GS_RETURN_IF_ERROR(Positive("speed", speed));
  GS_RETURN_IF_ERROR(Positive("dt", dt));
  GS_RETURN_IF_ERROR(Positive("sensor_range", sensor_range));
  GS_RETURN_IF_ERROR(Positive("field_of_view", field_of_view));
  if (field_of_view > 2.0 * std::numbers::pi) {
    return Status::InvalidArgument("field_of_view must be <= 2 pi, got " +
                                   std::to_string(field_of_view));
  }
  GS_RETURN_IF_ERROR(Positive("range_sigma", range_sigma));
  GS_RETURN_IF_ERROR(Positive("bearing_sigma", bearing_sigma));
  GS_RETURN_IF_ERROR(Positive("gps_sigma", gps_sigma));
  GS_RETURN_IF_ERROR(NonNegative("initial_position_sigma", initial_position_sigma));
  GS_RETURN_IF_ERROR(NonNegative("initial_heading_sigma", initial_heading_sigma));
  for (int i = 0; i < 6; ++i) {
    const std::string name = "noise.alpha[" + std::to_string(i) + "] (a" + std::to_string(i + 1) + ")";
    GS_RETURN_IF_ERROR(NonNegative(name.c_str(), noise.alpha[i]));
  }
  GS_RETURN_IF_ERROR(Positive("noise.min_sigma_xy", noise.min_sigma_xy));
  GS_RETURN_IF_ERROR(Positive("noise.min_sigma_theta", noise.min_sigma_theta));
  return Status::Ok();
}

namespace {

// Run `run` (run_poses poses): from a random intersection, pure pursuit
// along random streets; the poses' guess is the dead reckoning of the
// controls (the first run starts at the truth, later ones off by the
// initial sigmas).
void DriveRun(const CampusSimulatorOptions& options, const Grid& grid, int run,
              int64_t run_poses, Random* random_out, SimulatedCampus* campus) {
  Random& random = *random_out;
  core::Problem2d& problem = campus->problem;
  const internal::RunStart start = internal::DrawRunStart(grid, &random);
  StreetPath path(grid, options, start.x, start.y, start.direction, &random);
  core::Pose2 truth = start.truth;
  core::Pose2 guess = internal::RunStartGuess(options, run, truth, &random);
  double s = 0.0;
  for (int64_t k = 0; k < run_poses; ++k) {
    const int32_t index = problem.AddPose(problem.num_poses(), guess, /*initialized=*/k == 0,
                                          /*line=*/0, static_cast<double>(k) * options.dt);
    if (run == 0 && k == 0 && options.gps_every == 0) problem.pose_fixed[index] = 1;
    campus->true_poses.push_back(truth);
    campus->run_of_pose.push_back(run);
    if (k + 1 == run_poses) break;

    // Pure pursuit on the true pose, executed with noise (campus_world.h).
    const core::VelocityControl control = internal::PursuitControl(options, truth, &path, &s);
    const core::Pose2 next = internal::ExecuteWithNoise(options, truth, control, &random);

    core::VelocityMotionConstraint motion;
    motion.from = index;
    motion.to = index + 1;
    motion.control = control;
    motion.information =
        SymmetricInverse(core::VelocityMotionCovariance(truth, control, options.noise));
    problem.motions.push_back(motion);

    campus->distance_travelled += (next.head<2>() - truth.head<2>()).norm();
    truth = next;
    guess = core::PredictVelocityMotion(guess, control);  // dead reckoning: the hint
  }
}

// Range-bearing observations of every landmark in range and field of view,
// pose after pose; a feature's guess is its first sight from the
// dead-reckoned pose (Table 1).
void SenseLandmarks(const CampusSimulatorOptions& options, const Grid& grid, Random* random_out,
                    SimulatedCampus* campus_out) {
  Random& random = *random_out;
  SimulatedCampus& campus = *campus_out;
  core::Problem2d& problem = campus.problem;
  const int64_t num_features = static_cast<int64_t>(campus.true_features.size());
  const double margin = 0.5 * options.street_width + options.sensor_range;
  LandmarkIndex index(campus.true_features, grid, options.sensor_range, margin);
  std::vector<int32_t> nearby;
  std::vector<uint8_t> seen(static_cast<size_t>(num_features), 0);
  const double half_fov = 0.5 * options.field_of_view;
  const Eigen::Matrix2d observation_information =
      Eigen::Vector2d(1.0 / (options.range_sigma * options.range_sigma),
                      1.0 / (options.bearing_sigma * options.bearing_sigma))
          .asDiagonal();
  // Ranges below this could come out <= 0 once noise is added.
  const double min_range = 5.0 * options.range_sigma;
  for (int32_t pose = 0; pose < problem.num_poses(); ++pose) {
    const core::Pose2& truth = campus.true_poses[static_cast<size_t>(pose)];
    index.Near(truth.head<2>(), options.sensor_range, &nearby);
    for (int32_t feature : nearby) {
      const core::Point2 delta = campus.true_features[static_cast<size_t>(feature)] - truth.head<2>();
      const double range = delta.norm();
      if (range < min_range || range > options.sensor_range) continue;
      const double bearing = core::WrapAngle(std::atan2(delta.y(), delta.x()) - truth.z());
      if (std::abs(bearing) > half_fov) continue;
      core::Observation observation;
      observation.pose = pose;
      observation.feature = feature;
      observation.kind = core::ObservationKind::kRangeBearing;
      observation.z = Eigen::Vector2d(range + random.Normal(options.range_sigma),
                                      core::WrapAngle(bearing + random.Normal(options.bearing_sigma)));
      observation.information = observation_information;
      problem.observations.push_back(observation);
      if (!seen[static_cast<size_t>(feature)]) {
        seen[static_cast<size_t>(feature)] = 1;
        ++campus.observed_features;
        // The hint: first sight from the dead-reckoned pose (Table 1).
        problem.features[static_cast<size_t>(feature)] =
            core::InvertRangeBearing(problem.poses[static_cast<size_t>(pose)], observation.z);
      }
    }
  }
}

// A GPS fix every gps_every-th pose of each run.
void AddGps(const CampusSimulatorOptions& options, Random* random_out, SimulatedCampus* campus_out) {
  Random& random = *random_out;
  SimulatedCampus& campus = *campus_out;
  core::Problem2d& problem = campus.problem;
  const Eigen::Matrix2d gps_information =
      Eigen::Matrix2d::Identity() / (options.gps_sigma * options.gps_sigma);
  int64_t k = 0;
  for (int32_t pose = 0; pose < problem.num_poses(); ++pose, ++k) {
    if (pose > 0 && campus.run_of_pose[static_cast<size_t>(pose)] !=
                        campus.run_of_pose[static_cast<size_t>(pose) - 1]) {
      k = 0;
    }
    if (k % options.gps_every != 0) continue;
    core::GpsConstraint gps;
    gps.pose = pose;
    const core::Pose2& truth = campus.true_poses[static_cast<size_t>(pose)];
    gps.z = Eigen::Vector2d(truth.x() + random.Normal(options.gps_sigma),
                            truth.y() + random.Normal(options.gps_sigma));
    gps.information = gps_information;
    problem.gps.push_back(gps);
  }
}

}  // namespace

StatusOr<SimulatedCampus> SimulateCampus(const CampusSimulatorOptions& options) {
  GS_RETURN_IF_ERROR(options.Validate());
  Random random(options.seed);
  SimulatedCampus campus;
  core::Problem2d& problem = campus.problem;
  problem.source = "simulated campus (seed " + std::to_string(options.seed) + ")";

  Grid grid;
  campus.true_features = BuildCampus(options, &random, &grid);
  campus.grid_columns = grid.columns;
  campus.grid_rows = grid.rows;
  const int64_t num_features = static_cast<int64_t>(campus.true_features.size());
  problem.features.reserve(static_cast<size_t>(num_features));
  problem.feature_ids.reserve(static_cast<size_t>(num_features));
  problem.feature_initialized.reserve(static_cast<size_t>(num_features));
  for (int64_t i = 0; i < num_features; ++i) {
    problem.AddFeature(options.feature_id_base + i, core::Point2::Zero(), /*initialized=*/false);
  }

  // Trajectories and controls, run after run.
  const size_t total_poses = static_cast<size_t>(options.poses);
  campus.true_poses.reserve(total_poses);
  campus.run_of_pose.reserve(total_poses);
  problem.poses.reserve(total_poses);
  problem.motions.reserve(total_poses);
  for (int run = 0; run < options.runs; ++run) {
    const int64_t run_poses =
        options.poses / options.runs + (run < options.poses % options.runs ? 1 : 0);
    DriveRun(options, grid, run, run_poses, &random, &campus);
  }
  SenseLandmarks(options, grid, &random, &campus);
  if (options.gps_every > 0) AddGps(options, &random, &campus);
  return campus;
}

}  // namespace graphslam::tools

// Reads one robot of the UTIAS Multi-Robot Cooperative Localization and
// Mapping dataset (Leung, Halpern, Barfoot, Liu, "The UTIAS multi-robot
// cooperative localization and mapping dataset", IJRR 2011) into a
// core::Problem2d with the velocity motion model of Thrun & Montemerlo.
//
// Folder contents (whitespace text, '#' header lines skipped; the raw files
// with irregular time stamps and the 50 Hz resampled ones both work):
//   RobotN_Odometry.dat     t v omega            (commanded velocities)
//   RobotN_Measurement.dat  t barcode range bearing
//   Barcodes.dat            subject barcode      (subjects 1..5 robots, 6..20 landmarks)
//   RobotN_Groundtruth.dat  t x y theta          (optional; Vicon)
//   Landmark_Groundtruth.dat subject x y sx sy   (optional)
//
// Poses: one per odometry record; pose k has time t_k and id k. Control record
// k drives pose k -> k+1:  u_k = (v_k, omega_k),  dt = t_{k+1} - t_k, and
//   Omega_k = R_k^{-1},  R_k = VelocityMotionCovariance(x_k, u_k, noise)
// (noise per unit time by default, DefaultMrclamNoise below),
// evaluated at the dead-reckoned pose x_k (x_0 (+) the controls so far), the
// only estimate available when reading. Pose 0 is the ground-truth pose
// nearest to t_0 if RobotN_Groundtruth.dat exists (and start_at_ground_truth),
// else the origin; it is initialized and fixed (the map frame is then the
// ground-truth frame). Poses
// 1..T-1 are uninitialized (pose_initialized = 0) but hold the dead-reckoned
// pose at which their motion information was linearized.
//
// Measurements: attached to the pose with the nearest time stamp (ties go to
// the earlier pose), dropped if that is farther than max_time_offset.
// Barcodes of robots (subjects 1..5) are dropped from the problem and counted;
// they are kept in MrclamReadStats::robot_sightings (a job of several robots
// of one dataset turns them into robot-to-robot constraints,
// tools/job/robot_sightings.h). A landmark barcode becomes feature id = its
// subject number (6..20), created uninitialized at its first observation.
// z = (range, bearing), kRangeBearing, information = the inverse of
// measurement_information^-1 + diag((range_sigma_per_meter * range)^2, 0).
//
// Standstill repeats (merge_standstill_repeats, known barcodes only): the
// camera sees a landmark again and again while the robot stands still (every
// control between the two poses is below MrclamStandsStill's deadband). Those
// readings repeat one error: in dataset 1 the readings of one landmark from
// one standstill scatter by 0.001-0.02 m about a mean that is 0.03-0.47 m off
// the survey, and robot 4 ends its run with 338 readings of landmark 10 all
// 0.22 m short. Counted as independent they weigh like 338 measurements and
// pull the pose and the map by their shared error. So all readings of one
// landmark from one standstill become ONE observation: z = their mean
// (circular mean of the bearing), at the pose of the first, with the
// information of one measurement.
//
// Barcodes in no row of Barcodes.dat: the published data has a few misread
// ones (dataset 1: barcode 43 in robots 3 and 5). Such a measurement is
// skipped and counted, its first lines are kept for the report, one warning
// is logged per file, and the read goes on.
//
// THREAD SAFETY: reentrant. ALLOCATION: O(records); files streamed by line.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "core/problem.h"
#include "core/status.h"
#include "core/velocity_motion_model.h"

namespace graphslam::storage {

// core::VelocityNoise's alphas and floor as densities (noise_time_constant
// tau, core/velocity_motion_model.h), so that the motion covariance does not
// depend on the 50 Hz logging rate. In dataset 1 the heading of the commanded
// velocities drifts from Vicon's by 0.08 rad rms over 4 s windows and 0.18
// rad over 16 s (all five robots); the model's variance tau * integral((a3 +
// a5) v^2 + (a4 + a6) w^2) dt matches those at tau = 0.27 s (4 s) to 0.31 s
// (16 s). tau = 0.2 s stays a little below: at 0.3 s a single robot solved
// from the odometry guess falls into a local minimum (robot 1: 1.16 m RMSE
// against Vicon, 0.094 m at 0.2 s). The per-step model (tau = 0) at 50 Hz is
// the same as tau = 0.02 s: 10 times too certain.
inline core::VelocityNoise DefaultMrclamNoise() {
  core::VelocityNoise noise;
  noise.noise_time_constant = 0.2;
  return noise;
}

struct MrclamOptions {
  int robot = 1;  // 1..5
  // true asks for unknown correspondences (barcodes ignored): every landmark
  // observation gets a feature of its own (id core::kNoFeatureId) for data
  // association (solve --associate); barcodes still tell robots from landmarks.
  bool ignore_barcodes = false;
  core::VelocityNoise noise = DefaultMrclamNoise();
  // diag(1/sigma_r^2, 1/sigma_phi^2) with sigma_r = 0.1 m and sigma_phi = 0.05
  // rad (about 3 degrees): our default, deliberately looser than the few-cm
  // errors of the camera so that occasional outliers do not dominate; tune it
  // for other data.
  Eigen::Matrix2d measurement_information =
      (Eigen::Matrix2d() << 1.0 / (0.1 * 0.1), 0.0, 0.0, 1.0 / (0.05 * 0.05)).finished();
  // The range error grows with the range (the camera's range comes from the
  // barcode's apparent size): per reading, the covariance is
  // measurement_information^-1 + diag((range_sigma_per_meter * range)^2, 0).
  // Dataset 1 against Vicon and the survey: robust sigma 0.06 m at 1.25 m,
  // 0.10 m at 2.25 m, 0.20 m at 4.25 m, 0.27 m at 6.75 m (about 0.04 r).
  double range_sigma_per_meter = 0.04;
  // Measurements farther than this from every odometry stamp are dropped [s].
  double max_time_offset = 0.5;
  // Readings of one landmark from one standstill become one observation
  // (above); false keeps every reading as its own observation.
  bool merge_standstill_repeats = true;
  // > 0: only the first `duration` seconds of the log (odometry records up to
  // t_0 + duration; later measurements have no pose and are dropped) [s].
  double duration = 0.0;
  // true: pose 0 starts at the ground-truth pose (the Vicon frame) when
  // RobotN_Groundtruth.dat exists; false: at the origin, in the robot's own
  // frame (a job of several robots, where nothing may give the runs their
  // relative placement).
  bool start_at_ground_truth = true;

  // InvalidArgument naming the bad field and its value.
  [[nodiscard]] Status Validate() const;
};

// True when a commanded (v, omega) does not move the robot: |v| < 0.01 m/s and
// |omega| < 0.01 rad/s. The logs command such rates while the robot stands:
// dataset 1's robot 3 is commanded omega = 0.003 rad/s for 1460-1500 s and
// its Vicon heading changes by 1e-4 rad; in 1 s they would move it < 1 cm.
inline bool MrclamStandsStill(double v, double omega) {
  return v > -0.01 && v < 0.01 && omega > -0.01 && omega < 0.01;
}

// A measurement of another robot's barcode, as read (not in the problem).
struct MrclamRobotSighting {
  double stamp = 0.0;       // s, the measurement's time
  int observed_robot = 0;   // subject 1..5
  Eigen::Vector2d z = Eigen::Vector2d::Zero();  // range, bearing
  Eigen::Matrix2d information = Eigen::Matrix2d::Identity();  // of this reading
  int32_t line = 0;         // in RobotN_Measurement.dat
};

// What ReadMrclam read and dropped.
struct MrclamReadStats {
  // How many "file:line: text" of unknown barcodes are kept.
  static constexpr size_t kMaxUnknownBarcodeLines = 5;

  int64_t odometry_records = 0;
  int64_t measurements = 0;             // all records of RobotN_Measurement.dat
  int64_t robot_measurements_dropped = 0;   // barcodes of robots
  int64_t out_of_time_range_dropped = 0;    // no pose within max_time_offset
  int64_t landmark_observations = 0;        // became Observations
  int64_t standstill_repeats_merged = 0;    // readings merged into an earlier one
  int64_t unknown_barcodes_skipped = 0;     // barcode in no row of Barcodes.dat
  // The first kMaxUnknownBarcodeLines of those, "Robot3_Measurement.dat:4938:
  // 942.52 43 1.992 -0.287".
  std::vector<std::string> unknown_barcode_lines;
  // Every robot barcode measurement, in file order.
  std::vector<MrclamRobotSighting> robot_sightings;
};

StatusOr<core::Problem2d> ReadMrclam(const std::string& folder, const MrclamOptions& options,
                                     MrclamReadStats* stats = nullptr);

struct MrclamGroundTruth {
  std::vector<double> stamps;              // RobotN_Groundtruth.dat
  std::vector<core::Pose2> poses;
  std::map<int64_t, core::Point2> landmarks;  // subject -> position
};

// Reads RobotN_Groundtruth.dat and Landmark_Groundtruth.dat (both required).
StatusOr<MrclamGroundTruth> ReadMrclamGroundTruth(const std::string& folder, int robot);

}  // namespace graphslam::storage

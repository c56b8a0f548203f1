// A small multi-run job end to end: a simulated campus driven twice (GPS on
// part of the poses) plus an unrelated run that shares nothing with them.
// The outputs exist and load, each trajectory matches the simulator's ground
// truth within the noise, the unrelated run is reported (not merged), and a
// bad job or bad input afterwards fails with file:line and leaves the
// earlier outputs byte for byte.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "storage/format_detection.h"
#include "storage/native_log_reader.h"
#include "tools/campus_simulator.h"
#include "tests/tools/job/job_test_folder.h"
#include "tools/job/job_runner.h"
#include "tools/trajectory_metrics.h"

namespace graphslam::tools::job {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using ::testing::Not;

using JobEndToEnd = JobTestFolder;

constexpr const char* kJob =
    "output: out\n"
    "threads: 2\n"
    "runs:\n"
    "  - name: campus\n"
    "    format: simulate\n"
    "    simulate: {poses: 800, runs: 2, gps_every: 10, seed: 4, gps_denied_region: [0, 0, 60, 60]}\n"
    "  - name: lonely\n"
    "    format: simulate\n"
    "    simulate: {poses: 200, seed: 5, feature_id_base: 5000000}\n";

TEST_F(JobEndToEnd, MultiRunJobWritesOutputsThatMatchGroundTruth) {
  const Status status = Run(kJob);
  ASSERT_TRUE(status.ok()) << status.ToString();
  const fs::path out = dir_ / "out";
  for (const char* file : {"trajectories/campus_1.tum", "trajectories/campus_2.tum",
                           "trajectories/lonely.tum", "features.csv", "graph.g2o", "report.json",
                           "report.html", "log.jsonl"})
    EXPECT_TRUE(fs::exists(out / file)) << file;
  // No scans: no map, and no stand-in file either.
  EXPECT_FALSE(fs::exists(out / "map.bt"));
  EXPECT_FALSE(fs::exists(out / "map.pcd"));

  // Ground truth straight from the simulator, independent of the job.
  CampusSimulatorOptions campus_options;
  campus_options.poses = 800;
  campus_options.runs = 2;
  campus_options.gps_every = 10;
  campus_options.seed = 4;
  StatusOr<SimulatedCampus> campus = SimulateCampus(campus_options);
  ASSERT_TRUE(campus.ok());
  // The simulator's times start at 0 in every run; the job's TUM files
  // continue them: run 2 starts 1 s after run 1 ended (tools/job/job_export.h).
  double offset = 0.0;
  for (int run = 0; run < 2; ++run) {
    std::vector<StampedPose2> truth;
    for (size_t i = 0; i < campus->true_poses.size(); ++i) {
      if (campus->run_of_pose[i] != run) continue;
      truth.push_back({offset + campus->problem.pose_stamps[i], campus->true_poses[i]});
    }
    offset = truth.back().stamp + 1.0;
    const std::string name = "trajectories/campus_" + std::to_string(run + 1);
    StatusOr<std::vector<StampedPose2>> estimate = ReadTum((out / (name + ".tum")).string());
    ASSERT_TRUE(estimate.ok()) << estimate.status().ToString();
    ASSERT_EQ(estimate->size(), truth.size());
    EXPECT_DOUBLE_EQ(estimate->front().stamp, truth.front().stamp);
    // The ground truth beside it, re-read: the same poses at the same times,
    // so `evo_ape tum campus_N_groundtruth.tum campus_N.tum` pairs them.
    StatusOr<std::vector<StampedPose2>> written =
        ReadTum((out / (name + "_groundtruth.tum")).string());
    ASSERT_TRUE(written.ok()) << written.status().ToString();
    ASSERT_EQ(written->size(), truth.size());
    for (size_t i = 0; i < truth.size(); ++i) {
      EXPECT_DOUBLE_EQ((*written)[i].stamp, truth[i].stamp);
      EXPECT_NEAR(((*written)[i].pose - truth[i].pose).norm(), 0.0, 1e-12);
    }

    // With GPS the estimate is in the true frame: compare without alignment.
    TrajectoryMatchOptions unaligned;
    unaligned.align = false;
    StatusOr<TrajectoryErrors> errors = CompareTrajectories(*estimate, truth, unaligned);
    ASSERT_TRUE(errors.ok()) << errors.status().ToString();
    EXPECT_EQ(errors->matched, static_cast<int64_t>(truth.size()));
    // Range noise 0.1 m, GPS 1 m every 10 poses: decimetres, not metres.
    EXPECT_LT(errors->position_rmse, 0.5) << "run " << run;
    EXPECT_LT(errors->heading_rmse_rad, 0.02) << "run " << run;
  }

  // The graph and the map load.
  StatusOr<core::Problem2d> graph =
      storage::ReadProblem((out / "graph.g2o").string(), storage::InputFormat::kG2o, {});
  ASSERT_TRUE(graph.ok()) << graph.status().ToString();
  EXPECT_EQ(graph->num_poses(), 1000);
  StatusOr<std::map<int64_t, core::Point2>> features = ReadFeaturesCsv((out / "features.csv").string());
  ASSERT_TRUE(features.ok()) << features.status().ToString();
  std::map<int64_t, core::Point2> true_features;
  for (size_t f = 0; f < campus->true_features.size(); ++f)
    true_features[campus->problem.feature_ids[f]] = campus->true_features[f];
  int64_t matched = 0;
  const double feature_rmse =
      FeatureRmse(*features, true_features, Eigen::Isometry2d::Identity(), &matched);
  EXPECT_GT(matched, 50);
  EXPECT_LT(feature_rmse, 0.5);

  // The report: the unrelated run is its own component, and said so.
  const nlohmann::json report = nlohmann::json::parse(ReadFile(out / "report.json"));
  for (int run = 0; run < 3; ++run) {
    EXPECT_EQ(report["runs"][run]["time"], "synthetic");
    const std::string name = report["runs"][run]["name"].get<std::string>();
    EXPECT_EQ(report["runs"][run]["ground_truth_trajectory"],
              "trajectories/" + name + "_groundtruth.tum");
  }
  // Times never restart: each run's TUM starts after the previous one ended.
  double previous_end = -1.0;
  for (const char* name : {"campus_1", "campus_2", "lonely"}) {
    StatusOr<std::vector<StampedPose2>> poses =
        ReadTum((out / "trajectories" / (std::string(name) + ".tum")).string());
    ASSERT_TRUE(poses.ok()) << poses.status().ToString();
    EXPECT_GT(poses->front().stamp, previous_end) << name;
    previous_end = poses->back().stamp;
  }
  ASSERT_EQ(report["components"].size(), 2u);
  ASSERT_EQ(report["runs"].size(), 3u);
  EXPECT_EQ(report["runs"][0]["component"], 0);
  EXPECT_EQ(report["runs"][1]["component"], 0);
  EXPECT_EQ(report["runs"][2]["component"], 1);
  EXPECT_FALSE(report["runs"][2]["tied"].get<bool>());
  EXPECT_THAT(report["warnings"].dump(), HasSubstr("run lonely is tied to no other run"));
  EXPECT_GT(report["runs"][0]["indoor_poses"].get<int>(), 0);
  EXPECT_LT(report["runs"][2]["position_rmse_m"].get<double>(), 0.5);
  EXPECT_EQ(report["stages"].size(), 6u);
  const std::string html = ReadFile(out / "report.html");
  EXPECT_GE(std::count(html.begin(), html.end(), '<') , 10);
  // Figures as inline SVG (tests/tools/job/report_html_test.cc checks what
  // they show): trajectories, the error over time of the three runs, a
  // residual histogram per constraint type (motion, landmarks, GPS), chi2
  // and damping per iteration; no map picture (no scans).
  size_t figures = 0;
  for (size_t at = html.find("<svg "); at != std::string::npos; at = html.find("<svg ", at + 1))
    ++figures;
  EXPECT_EQ(figures, 9u);
  EXPECT_THAT(html, Not(HasSubstr("<figure class=\"map-image")));
  // The structured log: one JSON object per line, every stage done.
  std::ifstream log(out / "log.jsonl");
  std::string line;
  int stages_done = 0;
  while (std::getline(log, line))
    if (nlohmann::json::parse(line)["event"] == "stage_done") ++stages_done;
  EXPECT_EQ(stages_done, 6);

  // A bad job file, then a bad input, into the same output folder: clear
  // errors with file:line, and the earlier outputs are untouched.
  const std::string graph_before = ReadFile(out / "graph.g2o");
  const std::string report_before = ReadFile(out / "report.json");
  const std::string tum_before = ReadFile(out / "trajectories/campus_1.tum");
  Status bad = Run("output: out\nruns:\n  - {name: x, format: simulate, simulate: {poses: -3}}\n",
                   "bad.yaml");
  ASSERT_FALSE(bad.ok());
  EXPECT_THAT(bad.message(), HasSubstr("bad.yaml:3:"));
  std::ofstream((dir_ / "broken.g2o").string())
      << "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nEDGE_SE2 0 1 1 0 zero 1 0 0 1 0 1\n";
  bad = Run("output: out\nruns:\n  - {name: x, format: g2o, path: broken.g2o}\n", "bad2.yaml");
  ASSERT_FALSE(bad.ok());
  EXPECT_THAT(bad.message(), HasSubstr("broken.g2o:3"));
  EXPECT_EQ(ReadFile(out / "graph.g2o"), graph_before);
  EXPECT_EQ(ReadFile(out / "report.json"), report_before);
  EXPECT_EQ(ReadFile(out / "trajectories/campus_1.tum"), tum_before);
}

// Run `run` of a simulated campus as a problem of its own, its guesses moved
// by `frame` (its own frame: where its odometry starts is unknown).
core::Problem2d SplitRun(const SimulatedCampus& campus, int run, const Eigen::Isometry2d& frame) {
  const core::Problem2d& all = campus.problem;
  core::Problem2d part;
  std::vector<int32_t> index(static_cast<size_t>(all.num_poses()), -1);
  const double angle = std::atan2(frame.linear()(1, 0), frame.linear()(0, 0));
  for (int32_t i = 0; i < all.num_poses(); ++i) {
    if (campus.run_of_pose[static_cast<size_t>(i)] != run) continue;
    const core::Pose2& p = all.poses[static_cast<size_t>(i)];
    const Eigen::Vector2d q = frame * p.head<2>();
    index[static_cast<size_t>(i)] =
        part.AddPose(all.pose_ids[static_cast<size_t>(i)], core::Pose2(q.x(), q.y(), p.z() + angle),
                     all.pose_initialized[static_cast<size_t>(i)] != 0, 0,
                     all.pose_stamps[static_cast<size_t>(i)]);
  }
  part.pose_fixed[0] = 1;
  for (int32_t f = 0; f < all.num_features(); ++f)
    part.AddFeature(all.feature_ids[static_cast<size_t>(f)], frame * all.features[static_cast<size_t>(f)],
                    false);
  for (core::VelocityMotionConstraint m : all.motions) {
    if (index[static_cast<size_t>(m.from)] < 0) continue;
    m.from = index[static_cast<size_t>(m.from)];
    m.to = index[static_cast<size_t>(m.to)];
    part.motions.push_back(m);
  }
  for (core::Observation o : all.observations) {
    if (index[static_cast<size_t>(o.pose)] < 0) continue;
    o.pose = index[static_cast<size_t>(o.pose)];
    part.observations.push_back(o);
  }
  return part;
}

TEST_F(JobEndToEnd, RunsInTheirOwnFramesAreTiedByTheLandmarksTheyShare) {
  // Two drives through one campus, saved as two native logs; the second one's
  // odometry starts in a frame rotated by 100 degrees and 300 m away.
  CampusSimulatorOptions sim;
  sim.poses = 1000;
  sim.runs = 2;
  sim.seed = 21;
  StatusOr<SimulatedCampus> campus = SimulateCampus(sim);
  ASSERT_TRUE(campus.ok());
  Eigen::Isometry2d far = Eigen::Isometry2d::Identity();
  far.rotate(100.0 * M_PI / 180.0);
  far.pretranslate(Eigen::Vector2d(300, -200));
  ASSERT_TRUE(storage::WriteNativeLog(SplitRun(*campus, 0, Eigen::Isometry2d::Identity()),
                                      (dir_ / "a.graphslam").string()).ok());
  ASSERT_TRUE(storage::WriteNativeLog(SplitRun(*campus, 1, far), (dir_ / "b.graphslam").string()).ok());
  // The same second drive, its odometry started in the true frame. Both jobs
  // solve to a tight tolerance: the runs' relative placement is a flat
  // direction of chi2 (the default 1e-6 leaves both within 2e-6 of the
  // optimum but 6 cm apart), and the comparison is of the optimum itself.
  ASSERT_TRUE(storage::WriteNativeLog(SplitRun(*campus, 1, Eigen::Isometry2d::Identity()),
                                      (dir_ / "b_true.graphslam").string()).ok());
  Status status = Run(
      "output: out\n"
      "solver: {function_tolerance: 1e-12}\n"
      "runs:\n"
      "  - {name: a, format: native, path: a.graphslam}\n"
      "  - {name: b, format: native, path: b.graphslam}\n");
  ASSERT_TRUE(status.ok()) << status.ToString();
  status = Run(
      "output: reference\n"
      "solver: {function_tolerance: 1e-12}\n"
      "runs:\n"
      "  - {name: a, format: native, path: a.graphslam}\n"
      "  - {name: b, format: native, path: b_true.graphslam}\n",
      "reference.yaml");
  ASSERT_TRUE(status.ok()) << status.ToString();
  // Both runs end in run a's frame, whatever frame b's odometry started in:
  // the result equals that of the job whose runs started in one frame.
  std::vector<StampedPose2> estimated, truth;
  for (const char* run : {"a", "b"}) {
    StatusOr<std::vector<StampedPose2>> moved =
        ReadTum((dir_ / "out/trajectories" / (std::string(run) + ".tum")).string());
    StatusOr<std::vector<StampedPose2>> reference =
        ReadTum((dir_ / "reference/trajectories" / (std::string(run) + ".tum")).string());
    ASSERT_TRUE(moved.ok() && reference.ok());
    ASSERT_EQ(moved->size(), reference->size());
    double sum = 0;
    for (size_t i = 0; i < moved->size(); ++i)
      sum += ((*moved)[i].pose.head<2>() - (*reference)[i].pose.head<2>()).squaredNorm();
    EXPECT_LT(std::sqrt(sum / static_cast<double>(moved->size())), 0.05) << run;
    estimated.insert(estimated.end(), moved->begin(), moved->end());
  }
  for (int run = 0; run < 2; ++run)
    for (size_t i = 0; i < campus->true_poses.size(); ++i)
      if (campus->run_of_pose[i] == run)
        truth.push_back({campus->problem.pose_stamps[i], campus->true_poses[i]});
  // And against the truth, one rigid alignment for both runs together.
  StatusOr<TrajectoryErrors> errors = CompareTrajectories(estimated, truth);
  ASSERT_TRUE(errors.ok()) << errors.status().ToString();
  EXPECT_EQ(errors->matched, static_cast<int64_t>(truth.size()));
  EXPECT_LT(errors->position_rmse, 0.5);
  const nlohmann::json report = nlohmann::json::parse(ReadFile(dir_ / "out/report.json"));
  EXPECT_EQ(report["components"].size(), 1u);
  EXPECT_TRUE(report["runs"][1]["tied"].get<bool>());
}

TEST_F(JobEndToEnd, GpsFixesInLatitudeLongitudeTieARunToALocalEnuFrame) {
  // A simulated drive saved as a native log (time-stamped poses, no GPS) and
  // GPS fixes of its true positions as latitude / longitude around
  // (48.1 N, 11.5 E), every 10th pose.
  CampusSimulatorOptions sim;
  sim.poses = 400;
  sim.seed = 7;
  StatusOr<SimulatedCampus> campus = SimulateCampus(sim);
  ASSERT_TRUE(campus.ok());
  ASSERT_TRUE(storage::WriteNativeLog(campus->problem, (dir_ / "drive.graphslam").string()).ok());
  std::ofstream fixes((dir_ / "fixes.csv").string());
  fixes.precision(15);
  fixes << "t,lat,lon\n";
  // Local metres per degree at lat0 (WGS84 series; ample for a few hundred m).
  const double lat0 = 48.1, lon0 = 11.5, phi = lat0 * M_PI / 180;
  const double per_lat = 111132.92 - 559.82 * std::cos(2 * phi) + 1.175 * std::cos(4 * phi);
  const double per_lon = 111412.84 * std::cos(phi) - 93.5 * std::cos(3 * phi);
  for (size_t i = 0; i < campus->true_poses.size(); i += 10) {
    fixes << campus->problem.pose_stamps[i] << "," << lat0 + campus->true_poses[i].y() / per_lat
          << "," << lon0 + campus->true_poses[i].x() / per_lon << "\n";
  }
  fixes.close();
  const Status status = Run(
      "output: out\n"
      "runs:\n"
      "  - {name: drive, format: native, path: drive.graphslam, gps: {path: fixes.csv, sigma: 0.5}}\n");
  ASSERT_TRUE(status.ok()) << status.ToString();
  // The ENU origin is the first fix (pose 0's true position), so the estimate
  // is the truth shifted by that position, without rotation.
  StatusOr<std::vector<StampedPose2>> estimate =
      ReadTum((dir_ / "out/trajectories/drive.tum").string());
  ASSERT_TRUE(estimate.ok());
  ASSERT_EQ(estimate->size(), campus->true_poses.size());
  double sum = 0;
  for (size_t i = 0; i < estimate->size(); ++i) {
    const Eigen::Vector2d truth = campus->true_poses[i].head<2>() - campus->true_poses[0].head<2>();
    sum += ((*estimate)[i].pose.head<2>() - truth).squaredNorm();
  }
  EXPECT_LT(std::sqrt(sum / static_cast<double>(estimate->size())), 0.5);
  const nlohmann::json report = nlohmann::json::parse(ReadFile(dir_ / "out/report.json"));
  EXPECT_NEAR(report["enu_origin"]["latitude"].get<double>(), lat0, 1e-4);
  EXPECT_EQ(report["runs"][0]["gps_fixes"].get<int>(), 40);

  // A malformed GPS file is named with its line.
  std::ofstream((dir_ / "bad_fixes.csv").string()) << "t,lat,lon\n0,48.1,11.5\n1,north,11.5\n";
  const Status bad = Run(
      "output: out2\n"
      "runs:\n"
      "  - {name: drive, format: native, path: drive.graphslam, gps: bad_fixes.csv}\n",
      "gps.yaml");
  ASSERT_FALSE(bad.ok());
  EXPECT_THAT(bad.message(), HasSubstr("bad_fixes.csv:3"));
}

}  // namespace
}  // namespace graphslam::tools::job

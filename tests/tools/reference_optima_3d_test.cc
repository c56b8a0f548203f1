// 3-D solves of real pose graphs end to end through `graphslam solve`:
//   - sphere2500, torus3D and parking-garage (SE-Sync's g2o files) reach the
//     chi2 of a converged peer within 0.1 % (../shared/datasets/INDEX.md), and
//     the chi2 of the written graph, recomputed here independently with 4x4
//     homogeneous matrices, equals the reported one;
//   - sphere2500 in iSAM's format solved against its noise-free ground truth
//     (isam_datasets/groundtruth): position RMSE after a rigid alignment.
#include <gtest/gtest.h>
#include <unistd.h>

#include <Eigen/Geometry>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <string>

#include "core/initialization_3d.h"
#include "storage/g2o_3d_reader.h"
#include "storage/isam_3d_reader.h"
#include "tests/testing/datasets.h"
#include "tests/testing/g2o_edge_se3_chi2.h"
#include "tools/exit_codes.h"
#include "tools/pipeline/solve_pipeline.h"
#include "tools/solve_command.h"

namespace graphslam::tools {
namespace {

// Measured: 0.1796 m after alignment (dead reckoning: 27.9 m). The noise of
// the file (sigma 0.1 m per odometry step on a 2500-pose sphere of radius
// ~50 m) bounds what any estimator reaches; 0.25 m leaves ~40 % room for
// other solver settings while still failing on any real loss of accuracy.
constexpr double kSphere2500RmseBound = 0.25;

std::string TempPath(const std::string& name) {
  return (std::filesystem::temp_directory_path() /
          ("graphslam_3d_" + std::to_string(::getpid()) + "_" + name))
      .string();
}

struct Solved {
  double final_chi2 = -1;
  bool converged = false;
  double written_chi2 = -1;
  int iterations = 0;
};

Solved SolveWithDefaults(const std::string& relative) {
  SolveCommandOptions options;
  options.input = graphslam::testing::DatasetPath(relative);
  options.report = TempPath("report.json");
  options.output_g2o = TempPath("out.g2o");
  options.quiet = true;
  Solved out;
  EXPECT_EQ(RunSolveCommand(options), kExitOk) << relative;
  std::ifstream in(options.report);
  const nlohmann::json json = nlohmann::json::parse(in, nullptr, false);
  if (!json.is_discarded()) {
    out.final_chi2 = json["final_chi2"].get<double>();
    out.converged = json["converged"].get<bool>();
    out.iterations = json["iterations"].get<int>();
    EXPECT_EQ(json["dimension"].get<int>(), 3);
    EXPECT_EQ(json["poses"].get<int>() > 0, true);
  }
  StatusOr<core::Problem3d> written = storage::ReadG2o3d(options.output_g2o);
  EXPECT_TRUE(written.ok()) << written.status().ToString();
  if (written.ok()) out.written_chi2 = graphslam::testing::G2oEdgeSe3Chi2(*written);
  std::filesystem::remove(options.report);
  std::filesystem::remove(options.output_g2o);
  return out;
}

void ExpectReached(const Solved& s, double reference) {
  EXPECT_TRUE(s.converged);
  EXPECT_GT(s.final_chi2, 0.0);
  EXPECT_LE(s.final_chi2, reference * 1.001) << "reference " << reference;
  // The written graph (17 significant digits) has the reported chi2.
  EXPECT_NEAR(s.written_chi2, s.final_chi2, 1e-6 * s.final_chi2);
}

TEST(ReferenceOptima3d, Sphere2500) {
  GS_REQUIRE_DATASET("sesync_posegraphs/sphere2500.g2o");
  ExpectReached(SolveWithDefaults("sesync_posegraphs/sphere2500.g2o"), 727.149471);
}

TEST(ReferenceOptima3d, ParkingGarage) {
  GS_REQUIRE_DATASET("sesync_posegraphs/parking-garage.g2o");
  ExpectReached(SolveWithDefaults("sesync_posegraphs/parking-garage.g2o"), 1.238684);
}

// parking-garage without its VERTEX lines (an edges-only file, as SE-Sync's
// CSAIL): the poses are chained from the odometry and the solve still reaches
// the reference; --tum writes one pose per line.
TEST(ReferenceOptima3d, EdgesOnlyParkingGarageIsChainedAndReachesTheOptimum) {
  GS_REQUIRE_DATASET("sesync_posegraphs/parking-garage.g2o");
  const std::string edges_only = TempPath("garage_edges.g2o");
  {
    std::ifstream in(graphslam::testing::DatasetPath("sesync_posegraphs/parking-garage.g2o"));
    std::ofstream out(edges_only);
    std::string line;
    while (std::getline(in, line))
      if (line.rfind("EDGE_", 0) == 0) out << line << "\n";
  }
  SolveCommandOptions options;
  options.input = edges_only;
  options.report = TempPath("garage_report.json");
  options.tum = TempPath("garage.tum");
  options.quiet = true;
  EXPECT_EQ(RunSolveCommand(options), kExitOk);
  std::ifstream report(options.report);
  const nlohmann::json json = nlohmann::json::parse(report, nullptr, false);
  ASSERT_FALSE(json.is_discarded());
  EXPECT_LE(json["final_chi2"].get<double>(), 1.238684 * 1.001);
  EXPECT_GT(json["initial_chi2"].get<double>(), 1.0);
  std::ifstream tum(options.tum);
  int lines = 0;
  for (std::string line; std::getline(tum, line);) lines += line.empty() || line[0] == '#' ? 0 : 1;
  EXPECT_EQ(lines, 1661);
  for (const std::string& path : {edges_only, options.report, options.tum})
    std::filesystem::remove(path);
}

// sphere2500 in iSAM's format against the noise-free trajectory it was made
// from (groundtruth/sphere2500_groundtruth.txt: the same EDGE3 records without
// noise, so chaining its odometry gives the true poses). Positions are
// compared after the best rigid alignment (Umeyama, no scale).
TEST(GroundTruth3d, Sphere2500IsamAgainstItsGroundTruth) {
  GS_REQUIRE_DATASET("isam_datasets/sphere2500.txt");
  GS_REQUIRE_DATASET("isam_datasets/groundtruth/sphere2500_groundtruth.txt");
  core::SolverOptions options;
  core::SolverSummary summary;
  StatusOr<core::OptimizedPoses3d> solved = SolvePoses3dFile(
      graphslam::testing::DatasetPath("isam_datasets/sphere2500.txt"), options, &summary);
  ASSERT_TRUE(solved.ok()) << solved.status().ToString();
  EXPECT_TRUE(summary.converged) << summary.termination;
  StatusOr<core::Problem3d> truth = storage::ReadIsam3d(
      graphslam::testing::DatasetPath("isam_datasets/groundtruth/sphere2500_groundtruth.txt"));
  ASSERT_TRUE(truth.ok()) << truth.status().ToString();
  // Odometry only: the chain along consecutive poses is the truth.
  core::Problem3d chain = *truth;
  chain.relative_poses.clear();
  for (const auto& c : truth->relative_poses)
    if (truth->pose_ids[c.to] == truth->pose_ids[c.from] + 1) chain.relative_poses.push_back(c);
  ASSERT_TRUE(core::InitializeProblem3d(&chain).ok());
  std::map<int64_t, Eigen::Vector3d> true_position;
  for (int i = 0; i < chain.num_poses(); ++i) true_position[chain.pose_ids[i]] = chain.poses[i].t;
  // The truth closes its own loops: every loop closure is satisfied.
  double worst_truth = 0.0;
  for (const auto& c : truth->relative_poses) {
    const core::Pose3 implied = core::Between(chain.poses[c.from], chain.poses[c.to]);
    worst_truth = std::max(worst_truth, (implied.t - c.z.t).norm());
  }
  EXPECT_LT(worst_truth, 1e-3);
  const int n = static_cast<int>(solved->ids.size());
  ASSERT_EQ(n, 2500);
  Eigen::Matrix3Xd estimate(3, n), reference(3, n), initial(3, n);
  for (int i = 0; i < n; ++i) {
    estimate.col(i) = solved->poses[i].t;
    reference.col(i) = true_position.at(solved->ids[i]);
  }
  auto aligned_rmse = [&](const Eigen::Matrix3Xd& points) {
    const Eigen::Matrix4d t = Eigen::umeyama(points, reference, /*with_scaling=*/false);
    const Eigen::Matrix3Xd moved =
        (t.topLeftCorner<3, 3>() * points).colwise() + Eigen::Vector3d(t.topRightCorner<3, 1>());
    return std::sqrt((moved - reference).colwise().squaredNorm().mean());
  };
  // Dead reckoning (the noisy file's odometry chained) for scale.
  StatusOr<core::Problem3d> noisy =
      storage::ReadIsam3d(graphslam::testing::DatasetPath("isam_datasets/sphere2500.txt"));
  ASSERT_TRUE(noisy.ok());
  core::Problem3d dead = *noisy;
  dead.relative_poses.clear();
  for (const auto& c : noisy->relative_poses)
    if (noisy->pose_ids[c.to] == noisy->pose_ids[c.from] + 1) dead.relative_poses.push_back(c);
  ASSERT_TRUE(core::InitializeProblem3d(&dead).ok());
  for (int i = 0; i < n; ++i) initial.col(i) = dead.poses[i].t;
  const double rmse = aligned_rmse(estimate);
  const double dead_rmse = aligned_rmse(initial);
  std::printf("sphere2500 position RMSE: solved %.6f m, dead reckoning %.6f m\n", rmse, dead_rmse);
  EXPECT_LT(rmse, kSphere2500RmseBound);
  EXPECT_LT(rmse, 0.05 * dead_rmse);
}
}  // namespace
}  // namespace graphslam::tools

// SimulateCampusStreaming (tools/streaming_campus_simulator.h): deterministic
// per seed, readable by the native log reader, and the same distribution as
// the in-memory SimulateCampus: landmark count, observations per pose,
// observed fraction, and measurement noise at the ground truth (normalized
// squared range / bearing residuals average 1).
#include "tools/streaming_campus_simulator.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <unordered_map>
#include <vector>

#include "core/angle.h"
#include "storage/native_log_reader.h"
#include "tools/campus_simulator.h"

namespace graphslam::tools {
namespace {

namespace fs = std::filesystem;

class StreamingCampusSimulatorTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const ::testing::TestInfo* info = ::testing::UnitTest::GetInstance()->current_test_info();
    root_ = fs::temp_directory_path() /
            ("graphslam_stream_sim_" + std::string(info->name()) + "_" + std::to_string(getpid()));
    fs::remove_all(root_);
    fs::create_directories(root_);
  }
  void TearDown() override { fs::remove_all(root_); }

  std::string Run(const CampusSimulatorOptions& options, const std::string& name,
                  StreamingCampusSummary* summary) {
    const fs::path dir = root_ / name;
    fs::create_directories(dir);
    const Status status = SimulateCampusStreaming(options, dir.string(), summary);
    EXPECT_TRUE(status.ok()) << status.ToString();
    return dir.string();
  }

  static std::string ReadBytes(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  }

  fs::path root_;
};

CampusSimulatorOptions Options(uint32_t seed) {
  CampusSimulatorOptions options;
  options.poses = 3000;
  options.features = 2000;
  options.runs = 2;
  options.gps_every = 25;
  options.seed = seed;
  return options;
}

TEST_F(StreamingCampusSimulatorTest, SameSeedSameFilesOtherSeedOtherFiles) {
  StreamingCampusSummary a, b, c;
  const std::string da = Run(Options(4), "a", &a);
  const std::string db = Run(Options(4), "b", &b);
  const std::string dc = Run(Options(5), "c", &c);
  for (const char* file : {"log.graphslam", "ground_truth.tum", "ground_truth_features.csv"}) {
    EXPECT_EQ(ReadBytes(da + "/" + file), ReadBytes(db + "/" + file)) << file;
    EXPECT_NE(ReadBytes(da + "/" + file), ReadBytes(dc + "/" + file)) << file;
  }
  EXPECT_EQ(a.observations, b.observations);
  EXPECT_FALSE(fs::exists(da + "/ground_truth.tum.tmp-" + std::to_string(getpid())));
}

TEST_F(StreamingCampusSimulatorTest, SameDistributionAsTheInMemorySimulator) {
  const CampusSimulatorOptions options = Options(7);
  StreamingCampusSummary summary;
  const std::string dir = Run(options, "s", &summary);
  StatusOr<SimulatedCampus> memory = SimulateCampus(options);
  ASSERT_TRUE(memory.ok());
  const double memory_observations = static_cast<double>(memory->problem.observations.size());

  // The same campus size; the landmark count is `features` in expectation.
  EXPECT_EQ(summary.grid_columns, memory->grid_columns);
  EXPECT_EQ(summary.grid_rows, memory->grid_rows);
  EXPECT_NEAR(static_cast<double>(summary.landmarks), 2000.0, 4.0 * std::sqrt(2000.0));
  EXPECT_EQ(summary.poses, options.poses);
  EXPECT_EQ(summary.motions, options.poses - options.runs);
  EXPECT_EQ(summary.gps, static_cast<int64_t>(memory->problem.gps.size()));
  // Observations per pose and observed fraction: same process, other draws.
  const double per_pose = static_cast<double>(summary.observations) / summary.poses;
  const double memory_per_pose = memory_observations / options.poses;
  EXPECT_NEAR(per_pose, memory_per_pose, 0.25 * memory_per_pose);
  EXPECT_NEAR(static_cast<double>(summary.observed_features) / summary.landmarks,
              static_cast<double>(memory->observed_features) / memory->problem.num_features(),
              0.25);

  // The log reads back; its observations are the truth plus the stated noise.
  StatusOr<core::Problem2d> read = storage::ReadNativeLog(dir + "/log.graphslam");
  ASSERT_TRUE(read.ok()) << read.status().ToString();
  const core::Problem2d& problem = *read;
  EXPECT_EQ(problem.num_poses(), options.poses);
  EXPECT_EQ(static_cast<int64_t>(problem.observations.size()), summary.observations);
  EXPECT_EQ(problem.num_features(), summary.observed_features);

  std::vector<core::Pose2> truth;
  {
    std::ifstream tum(dir + "/ground_truth.tum");
    std::string line;
    std::getline(tum, line);
    while (std::getline(tum, line)) {
      std::istringstream fields(line);
      double t, x, y, z, qx, qy, qz, qw;
      fields >> t >> x >> y >> z >> qx >> qy >> qz >> qw;
      truth.emplace_back(x, y, 2.0 * std::atan2(qz, qw));
    }
  }
  ASSERT_EQ(static_cast<int64_t>(truth.size()), options.poses);
  std::unordered_map<int64_t, core::Point2> landmarks;
  std::unordered_map<int64_t, int64_t> counts;
  {
    std::ifstream csv(dir + "/ground_truth_features.csv");
    std::string line;
    std::getline(csv, line);
    while (std::getline(csv, line)) {
      std::istringstream fields(line);
      std::string id, x, y, n;
      std::getline(fields, id, ',');
      std::getline(fields, x, ',');
      std::getline(fields, y, ',');
      std::getline(fields, n, ',');
      landmarks[std::stoll(id)] = core::Point2(std::stod(x), std::stod(y));
      counts[std::stoll(id)] = std::stoll(n);
    }
  }
  EXPECT_EQ(static_cast<int64_t>(landmarks.size()), summary.landmarks);
  double range_chi2 = 0, bearing_chi2 = 0;
  std::unordered_map<int64_t, int64_t> seen;
  for (const core::Observation& o : problem.observations) {
    const int64_t id = problem.feature_ids[o.feature];
    ASSERT_TRUE(landmarks.count(id)) << "observation of unknown landmark " << id;
    ++seen[id];
    const core::Pose2& x = truth[static_cast<size_t>(o.pose)];
    const core::Point2 delta = landmarks[id] - x.head<2>();
    const double dr = o.z.x() - delta.norm();
    const double db = core::WrapAngle(o.z.y() - (std::atan2(delta.y(), delta.x()) - x.z()));
    range_chi2 += dr * dr * o.information(0, 0);
    bearing_chi2 += db * db * o.information(1, 1);
  }
  for (const auto& [id, n] : seen) EXPECT_EQ(counts[id], n) << "landmark " << id;
  const double n = static_cast<double>(problem.observations.size());
  // Mean of chi2(1) draws: 1 +- 5 sigma of sqrt(2 / n).
  EXPECT_NEAR(range_chi2 / n, 1.0, 5.0 * std::sqrt(2.0 / n));
  EXPECT_NEAR(bearing_chi2 / n, 1.0, 5.0 * std::sqrt(2.0 / n));
}

// `simulate --landmark-spacing` for scaling runs: the same campus with
// landmarks 0.1 m apart holds 2 (28 / 0.1 + 0.5) per street segment instead
// of ~7, and each pose sees tens of them instead of a few.
TEST_F(StreamingCampusSimulatorTest, DenseLandmarkSpacingFillsTheStreets) {
  CampusSimulatorOptions options = Options(3);
  options.features = 0;  // campus sized by the path, as for the default spacing
  options.poses = 400;
  StreamingCampusSummary sparse;
  Run(options, "sparse", &sparse);
  options.min_landmark_spacing = options.max_landmark_spacing = 0.1;
  options.sensor_range = 8;
  StreamingCampusSummary dense;
  Run(options, "dense", &dense);
  ASSERT_EQ(dense.grid_columns, sparse.grid_columns);
  ASSERT_EQ(dense.grid_rows, sparse.grid_rows);
  const int64_t segments =
      static_cast<int64_t>(dense.grid_columns) * (dense.grid_rows - 1) +
      static_cast<int64_t>(dense.grid_rows) * (dense.grid_columns - 1);
  // Per side: slots at t0 + 0.1 k for t0 in [6, 6.05], t <= 34: 280 or 281.
  EXPECT_GE(dense.landmarks, segments * 2 * 280);
  EXPECT_LE(dense.landmarks, segments * 2 * 281);
  const double sparse_per_pose = static_cast<double>(sparse.observations) / sparse.poses;
  const double dense_per_pose = static_cast<double>(dense.observations) / dense.poses;
  EXPECT_GT(dense_per_pose, 20.0 * sparse_per_pose) << sparse_per_pose << " " << dense_per_pose;
  // Each observed landmark is seen from a few poses as the robot passes it.
  EXPECT_GT(static_cast<double>(dense.observations) / dense.observed_features, 2.0);
}

TEST_F(StreamingCampusSimulatorTest, InvalidOptionsAreRejectedBeforeWriting) {
  CampusSimulatorOptions options = Options(1);
  options.runs = 0;
  StreamingCampusSummary summary;
  const Status status = SimulateCampusStreaming(options, root_.string(), &summary);
  EXPECT_FALSE(status.ok());
  EXPECT_FALSE(fs::exists(root_ / "log.graphslam"));
}

}  // namespace
}  // namespace graphslam::tools

// `graphslam solve` on TORO / GTSAM .graph files (storage/toro_reader.h) ends
// at the optimum of the problem as the format defines it:
//
// 2-D (GTSAM's w100.graph and example.graph): the test reads the file with its
// own few lines of parsing, evaluates chi2 = sum e^T Omega e with its own
// residuals (g2o's relative-pose error t2v(Z^-1 X_i^-1 X_j) and the
// range-bearing error), and checks at the solver's output that
//   - this chi2 equals the chi2 the solver reports (same problem read), and
//   - its gradient (central differences) vanishes: a stationary point, and
//     no step along it lowers chi2 (a minimum, not a saddle).
// 3-D: smallGrid3D.g2o rewritten as VERTEX3 / EDGE3 (roll-pitch-yaw, the
// information over the angles, i.e. the g2o rotation block / 4) solves to the
// same chi2 and poses as the g2o file itself.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "tests/testing/datasets.h"
#include "tests/testing/subprocess.h"

namespace graphslam::tools {
namespace {

namespace fs = std::filesystem;

double Wrap(double angle) { return std::atan2(std::sin(angle), std::cos(angle)); }

struct Edge {
  int64_t i, j;
  Eigen::Vector3d z;
  Eigen::Matrix3d information;
};
struct BearingRange {
  int64_t pose, landmark;
  double bearing, range, sigma_bearing, sigma_range;
};
struct Graph {
  std::vector<Edge> edges;
  std::vector<BearingRange> observations;
};

// The constraints of a .graph file, parsed independently of the reader.
Graph ParseGraph(const std::string& path) {
  Graph graph;
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream fields(line);
    std::string tag;
    fields >> tag;
    if (tag == "EDGE2") {
      Edge e;
      double v[6];
      fields >> e.i >> e.j >> e.z(0) >> e.z(1) >> e.z(2);
      for (double& x : v) fields >> x;
      e.information << v[0], v[1], v[4], v[1], v[2], v[5], v[4], v[5], v[3];
      graph.edges.push_back(e);
    } else if (tag == "BR") {
      BearingRange o;
      fields >> o.pose >> o.landmark >> o.bearing >> o.range >> o.sigma_bearing >> o.sigma_range;
      graph.observations.push_back(o);
    }
  }
  return graph;
}

// The unknowns as the solver wrote them (g2o VERTEX_SE2 / VERTEX_XY).
struct Estimate {
  std::map<int64_t, Eigen::Vector3d> poses;
  std::map<int64_t, Eigen::Vector2d> points;
};

Estimate ReadEstimate(const std::string& path) {
  Estimate estimate;
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream fields(line);
    std::string tag;
    int64_t id = 0;
    fields >> tag >> id;
    if (tag == "VERTEX_SE2") {
      Eigen::Vector3d& p = estimate.poses[id];
      fields >> p(0) >> p(1) >> p(2);
    } else if (tag == "VERTEX_XY") {
      Eigen::Vector2d& p = estimate.points[id];
      fields >> p(0) >> p(1);
    }
  }
  return estimate;
}

double Chi2(const Graph& graph, const Estimate& x) {
  double chi2 = 0.0;
  auto rotate = [](double angle, const Eigen::Vector2d& v) {
    return Eigen::Vector2d(std::cos(angle) * v.x() - std::sin(angle) * v.y(),
                           std::sin(angle) * v.x() + std::cos(angle) * v.y());
  };
  for (const Edge& e : graph.edges) {
    const Eigen::Vector3d& a = x.poses.at(e.i);
    const Eigen::Vector3d& b = x.poses.at(e.j);
    // X_i^-1 X_j, then Z^-1 times it.
    const Eigen::Vector2d t = rotate(-a(2), b.head<2>() - a.head<2>());
    Eigen::Vector3d r;
    r.head<2>() = rotate(-e.z(2), t - e.z.head<2>());
    r(2) = Wrap(b(2) - a(2) - e.z(2));
    chi2 += r.dot(e.information * r);
  }
  for (const BearingRange& o : graph.observations) {
    const Eigen::Vector3d& p = x.poses.at(o.pose);
    const Eigen::Vector2d d = x.points.at(o.landmark) - p.head<2>();
    const double range_error = d.norm() - o.range;
    const double bearing_error = Wrap(std::atan2(d.y(), d.x()) - p(2) - o.bearing);
    chi2 += range_error * range_error / (o.sigma_range * o.sigma_range) +
            bearing_error * bearing_error / (o.sigma_bearing * o.sigma_bearing);
  }
  return chi2;
}

// Every coordinate except those of the anchor (the first pose, held fixed).
std::vector<double*> Coordinates(Estimate* x) {
  std::vector<double*> out;
  bool first = true;
  for (auto& [id, p] : x->poses) {
    if (first) {
      first = false;
      continue;
    }
    for (int k = 0; k < 3; ++k) out.push_back(&p(k));
  }
  for (auto& [id, p] : x->points)
    for (int k = 0; k < 2; ++k) out.push_back(&p(k));
  return out;
}

class ToroGraphSolve : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("graphslam_toro_" + std::to_string(getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // Solves `input` to a tight tolerance; the output graph and report.
  nlohmann::json Solve(const std::string& input, const std::string& name) {
    const testing::GraphslamRun run = testing::RunGraphslamCaptured(
        {"solve", input, "-o", (dir_ / (name + ".g2o")).string(), "--report",
         (dir_ / (name + ".json")).string(), "--function-tolerance", "1e-12",
         "--max-iterations", "200", "-q"},
        (dir_ / name).string());
    EXPECT_EQ(run.exit_code, 0) << run.err;
    std::ifstream in(dir_ / (name + ".json"));
    return nlohmann::json::parse(in);
  }

  void ExpectOptimum(const std::string& dataset, const std::string& name) {
    const std::string path = testing::DatasetPath(dataset);
    const nlohmann::json report = Solve(path, name);
    EXPECT_EQ(report["format"], "toro");
    const Graph graph = ParseGraph(path);
    Estimate x = ReadEstimate((dir_ / (name + ".g2o")).string());
    const double chi2 = Chi2(graph, x);
    EXPECT_NEAR(chi2, report["final_chi2"].get<double>(), 1e-8 * chi2);
    // Stationary: the gradient of the independent chi2 vanishes.
    std::vector<double*> coordinates = Coordinates(&x);
    std::vector<double> gradient(coordinates.size());
    double max_gradient = 0.0;
    const double h = 1e-6;
    for (size_t k = 0; k < coordinates.size(); ++k) {
      const double saved = *coordinates[k];
      *coordinates[k] = saved + h;
      const double plus = Chi2(graph, x);
      *coordinates[k] = saved - h;
      const double minus = Chi2(graph, x);
      *coordinates[k] = saved;
      gradient[k] = (plus - minus) / (2 * h);
      max_gradient = std::max(max_gradient, std::abs(gradient[k]));
    }
    std::printf("%s: chi2 %.10g, max |gradient| %.3g over %zu unknowns\n", name.c_str(), chi2,
                max_gradient, coordinates.size());
    EXPECT_LT(max_gradient, 1e-4);
    // A minimum: no step along -gradient lowers chi2 by more than rounding.
    for (double step : {1e-2, 1e-4, 1e-6}) {
      for (size_t k = 0; k < coordinates.size(); ++k) *coordinates[k] -= step * gradient[k];
      EXPECT_GE(Chi2(graph, x), chi2 * (1 - 1e-10)) << "step " << step;
      for (size_t k = 0; k < coordinates.size(); ++k) *coordinates[k] += step * gradient[k];
    }
  }

  fs::path dir_;
};

TEST_F(ToroGraphSolve, W100ReachesTheOptimum) {
  GS_REQUIRE_DATASET("gtsam_examples/w100.graph");
  ExpectOptimum("gtsam_examples/w100.graph", "w100");
}

TEST_F(ToroGraphSolve, ExampleWithBearingRangeReachesTheOptimum) {
  GS_REQUIRE_DATASET("gtsam_examples/example.graph");
  ExpectOptimum("gtsam_examples/example.graph", "example");
}

// smallGrid3D.g2o as a TORO 3-D file: the same problem, the same optimum.
TEST_F(ToroGraphSolve, ThreeDimensionalMatchesTheG2oFile) {
  GS_REQUIRE_DATASET("sesync_posegraphs/smallGrid3D.g2o");
  const std::string g2o = testing::DatasetPath("sesync_posegraphs/smallGrid3D.g2o");
  const std::string graph = (dir_ / "grid.graph").string();
  {
    std::ifstream in(g2o);
    std::FILE* out = std::fopen(graph.c_str(), "w");
    ASSERT_NE(out, nullptr);
    auto rpy = [](const Eigen::Quaterniond& q) {
      const Eigen::Vector3d ypr = q.normalized().toRotationMatrix().eulerAngles(2, 1, 0);
      return Eigen::Vector3d(ypr(2), ypr(1), ypr(0));
    };
    std::string line;
    while (std::getline(in, line)) {
      std::istringstream fields(line);
      std::string tag;
      fields >> tag;
      if (tag == "VERTEX_SE3:QUAT") {
        int64_t id;
        double t[3], q[4];
        fields >> id >> t[0] >> t[1] >> t[2] >> q[0] >> q[1] >> q[2] >> q[3];
        const Eigen::Vector3d a = rpy(Eigen::Quaterniond(q[3], q[0], q[1], q[2]));
        std::fprintf(out, "VERTEX3 %lld %.17g %.17g %.17g %.17g %.17g %.17g\n",
                     static_cast<long long>(id), t[0], t[1], t[2], a(0), a(1), a(2));
      } else if (tag == "EDGE_SE3:QUAT") {
        int64_t i, j;
        double t[3], q[4], upper[21];
        fields >> i >> j >> t[0] >> t[1] >> t[2] >> q[0] >> q[1] >> q[2] >> q[3];
        for (double& v : upper) fields >> v;
        const Eigen::Vector3d a = rpy(Eigen::Quaterniond(q[3], q[0], q[1], q[2]));
        std::fprintf(out, "EDGE3 %lld %lld %.17g %.17g %.17g %.17g %.17g %.17g",
                     static_cast<long long>(i), static_cast<long long>(j), t[0], t[1], t[2],
                     a(0), a(1), a(2));
        // Information over vec(q) -> over the angles: rotation rows/columns / 2.
        int k = 0;
        for (int r = 0; r < 6; ++r)
          for (int c = r; c < 6; ++c)
            std::fprintf(out, " %.17g", upper[k++] / ((r >= 3 ? 2.0 : 1.0) * (c >= 3 ? 2.0 : 1.0)));
        std::fprintf(out, "\n");
      }
    }
    std::fclose(out);
  }
  const nlohmann::json from_g2o = Solve(g2o, "grid_g2o");
  const nlohmann::json from_graph = Solve(graph, "grid_graph");
  EXPECT_EQ(from_graph["format"], "toro");
  EXPECT_EQ(from_graph["dimension"], 3);
  const double reference = from_g2o["final_chi2"].get<double>();
  EXPECT_NEAR(from_graph["final_chi2"].get<double>(), reference, 1e-7 * reference);
  EXPECT_NEAR(from_graph["initial_chi2"].get<double>(), from_g2o["initial_chi2"].get<double>(),
              1e-7 * from_g2o["initial_chi2"].get<double>());
  // The written poses agree.
  auto read_poses = [](const fs::path& path) {
    std::map<int64_t, Eigen::Vector3d> poses;
    std::ifstream in(path);
    std::string line;
    while (std::getline(in, line)) {
      std::istringstream fields(line);
      std::string tag;
      int64_t id;
      fields >> tag >> id;
      if (tag == "VERTEX_SE3:QUAT") fields >> poses[id](0) >> poses[id](1) >> poses[id](2);
    }
    return poses;
  };
  const auto a = read_poses(dir_ / "grid_g2o.g2o"), b = read_poses(dir_ / "grid_graph.g2o");
  ASSERT_EQ(a.size(), 125u);
  ASSERT_EQ(b.size(), a.size());
  for (const auto& [id, p] : a) EXPECT_LT((b.at(id) - p).norm(), 1e-6) << "pose " << id;
}

}  // namespace
}  // namespace graphslam::tools

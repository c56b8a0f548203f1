// Points fused per second: OctoMap's serial OcTree::insertPointCloud against
// our tiled parallel fusion (partition/fusion/tiled_fusion.h, TBB) on the same scans in
// one run, checking that both maps have the same occupied cells.
//
//   map_fusion_perf [--3dtk DIR] [--campus COLUMNS ROWS SPACING] [--resolution R]
//                   [--max-range M] [--threads N]
//
// Prints one line per method and the speed-up (docs/benchmarks.md).
#include <tbb/global_control.h>

#include <chrono>
#include <ctime>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <set>
#include <string>
#include <tuple>
#include <vector>

#include "tools/campus_3d.h"
#include "storage/scan_store.h"
#include "storage/threedtk_reader.h"
#include "partition/fusion/tiled_fusion.h"

namespace {

using graphslam::map::WorldScan;
using Cell = std::tuple<int, int, int>;

std::set<Cell> Occupied(octomap::OcTree* tree) {
  std::set<Cell> cells;
  for (auto it = tree->begin_leafs(tree->getTreeDepth()); it != tree->end_leafs(); ++it) {
    if (tree->isNodeOccupied(*it)) cells.insert({it.getKey()[0], it.getKey()[1], it.getKey()[2]});
  }
  return cells;
}

double Seconds(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace

int main(int argc, char** argv) {
  std::string threedtk;
  int columns = 0, rows = 0;
  double spacing = 1.0;
  graphslam::map::FusionOptions options;
  int threads = 0;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--3dtk" && i + 1 < argc) {
      threedtk = argv[++i];
    } else if (a == "--campus" && i + 3 < argc) {
      columns = std::atoi(argv[++i]);
      rows = std::atoi(argv[++i]);
      spacing = std::atof(argv[++i]);
    } else if (a == "--resolution" && i + 1 < argc) {
      options.resolution = std::atof(argv[++i]);
    } else if (a == "--max-range" && i + 1 < argc) {
      options.max_range = std::atof(argv[++i]);
    } else if (a == "--threads" && i + 1 < argc) {
      threads = std::atoi(argv[++i]);
    } else {
      std::fprintf(stderr, "usage: %s [--3dtk DIR] [--campus COLUMNS ROWS SPACING] "
                           "[--resolution R] [--max-range M] [--threads N]\n", argv[0]);
      return 1;
    }
  }
  std::vector<WorldScan> scans;
  auto add = [&](const graphslam::map::Scan& scan) {
    WorldScan world;
    world.origin = scan.sensor_pose.t.cast<float>();
    world.points = graphslam::map::WorldPoints(scan);
    scans.push_back(std::move(world));
  };
  if (!threedtk.empty()) {
    auto numbers = graphslam::map::List3dtkScans(threedtk);
    if (!numbers.ok()) {
      std::fprintf(stderr, "%s\n", numbers.status().ToString().c_str());
      return 2;
    }
    for (int n : *numbers) {
      auto scan = graphslam::map::Read3dtkScan(threedtk, n, n);
      if (!scan.ok()) {
        std::fprintf(stderr, "%s\n", scan.status().ToString().c_str());
        return 2;
      }
      add(*scan);
    }
  }
  if (columns > 0) {
    graphslam::map::Campus3dOptions c;
    c.columns = columns;
    c.rows = rows;
    c.pose_spacing = spacing;
    const graphslam::map::Campus3d campus = graphslam::map::MakeCampus3d(c);
    graphslam::Status status = graphslam::map::SimulateCampus3dScans(
        campus, [&](graphslam::map::Scan&& scan) {
          add(scan);
          return graphslam::Status::Ok();
        });
    if (!status.ok()) {
      std::fprintf(stderr, "%s\n", status.ToString().c_str());
      return 2;
    }
  }
  if (scans.empty()) {
    std::fprintf(stderr, "no scans: give --3dtk DIR and/or --campus C R S\n");
    return 1;
  }
  int64_t points = 0;
  for (const WorldScan& s : scans) points += static_cast<int64_t>(s.points.size());
  std::unique_ptr<tbb::global_control> limit;
  if (threads > 0) {
    limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                                  static_cast<size_t>(threads));
  }
  std::printf("%zu scans, %lld points, resolution %.3f m, max range %.1f m, tile %d leaves\n",
              scans.size(), static_cast<long long>(points), options.resolution, options.max_range,
              1 << options.tile_bits);

  auto start = std::chrono::steady_clock::now();
  std::clock_t cpu = std::clock();
  std::unique_ptr<octomap::OcTree> serial = graphslam::map::FuseSerial(options, scans);
  const double serial_seconds = Seconds(start);
  const double serial_cpu = static_cast<double>(std::clock() - cpu) / CLOCKS_PER_SEC;
  cpu = std::clock();

  start = std::chrono::steady_clock::now();
  graphslam::map::TiledFusion fusion(options);
  size_t batch_begin = 0;
  int64_t batch_points = 0;
  for (size_t i = 0; i < scans.size(); ++i) {
    batch_points += static_cast<int64_t>(scans[i].points.size());
    if (batch_points >= 2'000'000 || i + 1 == scans.size()) {
      const graphslam::Status status =
          fusion.Insert(std::vector<WorldScan>(scans.begin() + static_cast<std::ptrdiff_t>(batch_begin),
                                               scans.begin() + static_cast<std::ptrdiff_t>(i + 1)));
      if (!status.ok()) {
        std::fprintf(stderr, "%s\n", status.ToString().c_str());
        return 2;
      }
      batch_begin = i + 1;
      batch_points = 0;
    }
  }
  std::unique_ptr<octomap::OcTree> tiled = std::move(fusion.Merge()).value();
  const double tiled_seconds = Seconds(start);
  const double tiled_cpu = static_cast<double>(std::clock() - cpu) / CLOCKS_PER_SEC;

  const std::set<Cell> a = Occupied(serial.get()), b = Occupied(tiled.get());
  std::printf("octomap insertPointCloud (serial): %8.3f s wall %8.3f s cpu  %12.0f points/s  "
              "%zu occupied cells\n",
              serial_seconds, serial_cpu, static_cast<double>(points) / serial_seconds, a.size());
  std::printf("tiled parallel fusion (TBB):       %8.3f s wall %8.3f s cpu  %12.0f points/s  "
              "%zu occupied cells\n",
              tiled_seconds, tiled_cpu, static_cast<double>(points) / tiled_seconds, b.size());
  std::printf("speed-up %.2fx; occupied cells %s\n", serial_seconds / tiled_seconds,
              a == b ? "IDENTICAL" : "DIFFER");
  return a == b ? 0 : 3;
}

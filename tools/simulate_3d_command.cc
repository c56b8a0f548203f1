#include "tools/simulate_3d_command.h"

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <cinttypes>
#include <cstdio>
#include <filesystem>
#include <sstream>

#include "storage/scan_store.h"
#include "storage/atomic_file.h"
#include "storage/env.h"
#include "tools/exit_codes.h"
#include "tools/option_checks.h"

namespace graphslam::tools {

void AddSimulate3dOptions(CLI::App* simulate, Simulate3dOptions* options) {
  map::Campus3dOptions& c = options->campus;
  simulate->add_flag("--3d", options->enabled, "simulate the 3-D campus (tools/campus_3d.h) instead");
  simulate->add_flag("--scans", options->scans, "with --3d: write the laser scans (DIR/scans/)");
  simulate->add_option("--columns", c.columns, "--3d: blocks along x")
      ->check(Integer(1, std::numeric_limits<int>::max()))
      ->capture_default_str();
  simulate->add_option("--rows", c.rows, "--3d: blocks along y")
      ->check(Integer(1, std::numeric_limits<int>::max()))
      ->capture_default_str();
  simulate->add_option("--block", c.block_size, "--3d: block pitch [m]")
      ->check(PositiveReal())
      ->capture_default_str();
  simulate->add_option("--street", c.street_width, "--3d: street width [m]")
      ->check(PositiveReal())
      ->capture_default_str();
  simulate->add_option("--pose-spacing", c.pose_spacing, "--3d: metres between poses")
      ->check(PositiveReal())
      ->capture_default_str();
  simulate->add_option("--beams", c.beams, "--3d: laser beams per (vertical, 360 deg) scan")
      ->check(Integer(1, std::numeric_limits<int>::max()))
      ->capture_default_str();
  simulate->add_option("--scan-range", c.max_range, "--3d: laser max range [m]")
      ->check(PositiveReal())
      ->capture_default_str();
  simulate->add_option("--scan-sigma", c.range_sigma, "--3d: laser range noise [m]")
      ->check(NonNegativeReal())
      ->capture_default_str();
}

int RunSimulate3dCommand(const std::string& output_dir, const Simulate3dOptions& options,
                         uint64_t seed, bool quiet) {
  auto fail = [](const Status& status) {
    std::fprintf(stderr, "graphslam simulate --3d: %s\n", status.ToString().c_str());
    return ExitCodeFor(status);
  };
  map::Campus3dOptions campus_options = options.campus;
  campus_options.seed = seed;
  if (Status status = campus_options.Validate(); !status.ok()) {
    std::fprintf(stderr, "graphslam simulate --3d: %s\n", status.message().c_str());
    return kExitUsage;
  }
  if (!options.scans) {
    std::fprintf(stderr, "graphslam simulate --3d: only --scans output is implemented; add --scans\n");
    return kExitUsage;
  }
  if (Status status = storage::Env::Default()->CreateDir(output_dir); !status.ok())
    return fail(status);

  const map::Campus3d campus = map::MakeCampus3d(campus_options);
  StatusOr<std::unique_ptr<map::ScanStoreWriter>> writer = map::ScanStoreWriter::Create(output_dir);
  if (!writer.ok()) return fail(writer.status());
  std::ostringstream tum;
  tum.precision(9);
  int64_t scans = 0, points = 0;
  Status status = map::SimulateCampus3dScans(campus, [&](map::Scan&& scan) {
    const core::Pose3& x = scan.sensor_pose;
    tum << static_cast<double>(scan.pose) * options.dt << ' ' << x.t.x() << ' ' << x.t.y() << ' '
        << x.t.z() << ' ' << x.q.x() << ' ' << x.q.y() << ' ' << x.q.z() << ' ' << x.q.w() << '\n';
    ++scans;
    points += static_cast<int64_t>(scan.points.size());
    return (*writer)->Add(scan);
  });
  if (status.ok()) status = (*writer)->Finish();
  if (!status.ok()) return fail(status);
  const std::filesystem::path folder(output_dir);
  status = storage::WriteStringAtomically(storage::Env::Default(),
                                          (folder / "ground_truth_3d.tum").string(), tum.str());
  if (!status.ok()) return fail(status);
  nlohmann::json world;
  world["ground"] = {{"slope_x", campus.options.slope_x}, {"slope_y", campus.options.slope_y}};
  world["block_size"] = campus.options.block_size;
  world["street_width"] = campus.options.street_width;
  nlohmann::json buildings = nlohmann::json::array();
  for (const map::Box& b : campus.buildings) {
    buildings.push_back({{"min", {b.lo.x(), b.lo.y(), b.lo.z()}}, {"max", {b.hi.x(), b.hi.y(), b.hi.z()}}});
  }
  world["buildings"] = buildings;
  nlohmann::json trees = nlohmann::json::array();
  for (const map::Tree& t : campus.trees) trees.push_back({t.xy.x(), t.xy.y()});
  world["trees"] = trees;
  world["crown_radius"] = campus.options.crown_radius;
  status = storage::WriteStringAtomically(storage::Env::Default(),
                                          (folder / "campus3d.json").string(), world.dump() + "\n");
  if (!status.ok()) return fail(status);
  if (!quiet) {
    std::printf("Simulated a 3-D campus of %d x %d blocks (%.0f m x %.0f m, seed %" PRIu64
                "): %zu buildings, %zu trees; %lld scans with %lld points. Wrote %s/scans/, "
                "ground_truth_3d.tum and campus3d.json.\n",
                campus.options.columns, campus.options.rows,
                campus.options.columns * campus.options.block_size,
                campus.options.rows * campus.options.block_size, seed, campus.buildings.size(),
                campus.trees.size(), static_cast<long long>(scans), static_cast<long long>(points),
                output_dir.c_str());
  }
  return kExitOk;
}

}  // namespace graphslam::tools

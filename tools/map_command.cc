#include "tools/map_command.h"

#include <CLI/CLI.hpp>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "core/logging.h"
#include "storage/chunk_store.h"
#include "storage/directory_lock.h"
#include "storage/env.h"
#include "storage/native_log_scans.h"
#include "storage/threedtk_reader.h"
#include "tools/exit_codes.h"
#include "tools/option_checks.h"
#include "tools/output_paths.h"

namespace graphslam::tools {

StatusOr<std::unique_ptr<map::ScanSource>> OpenScanSource(const std::string& input) {
  if (map::DiskScanStore::Exists(input)) {
    GS_ASSIGN_OR_RETURN(std::unique_ptr<map::DiskScanStore> store, map::DiskScanStore::Open(input));
    return std::unique_ptr<map::ScanSource>(std::move(store));
  }
  if (map::IsNativeLogFile(input)) {  // SCAN records naming .pcd files
    GS_ASSIGN_OR_RETURN(std::unique_ptr<map::NativeLogScanSource> source,
                        map::NativeLogScanSource::Open(input));
    return std::unique_ptr<map::ScanSource>(std::move(source));
  }
  if (map::List3dtkScans(input).ok()) {
    GS_ASSIGN_OR_RETURN(std::unique_ptr<map::ThreeDtkScanSource> source,
                        map::ThreeDtkScanSource::Open(input));
    return std::unique_ptr<map::ScanSource>(std::move(source));
  }
  return Status::NotFound(input +
                          ": no scans (expected scans/SCANS.json, 3DTK scanNNN.3d files or a "
                          "native log with SCAN records)");
}

StatusOr<std::vector<core::Pose3>> ReadTumPoses(const std::string& path) {
  GS_ASSIGN_OR_RETURN(const std::string text,
                      storage::ReadFileToString(storage::Env::Default(), path,
                                                path + ": cannot open"));
  std::istringstream in(text);
  std::vector<core::Pose3> poses;
  std::string line;
  int64_t line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    double v[8];
    int n = 0;
    while (n < 8 && fields >> v[n]) ++n;
    std::string extra;
    if (n != 8 || (fields >> extra)) {
      return Status::Corruption(path + ":" + std::to_string(line_no) +
                                ": expected 8 numbers (stamp tx ty tz qx qy qz qw), got '" + line + "'");
    }
    core::Pose3 pose;
    pose.t = Eigen::Vector3d(v[1], v[2], v[3]);
    pose.q = Eigen::Quaterniond(v[7], v[4], v[5], v[6]);
    const double norm = pose.q.norm();
    if (!std::isfinite(norm) || std::abs(norm - 1.0) > 1e-3 || !pose.t.allFinite()) {
      return Status::Corruption(path + ":" + std::to_string(line_no) +
                                ": quaternion norm " + std::to_string(norm) + ", expected 1");
    }
    pose.q.normalize();
    poses.push_back(pose);
  }
  return poses;
}

void AddMapCommand(CLI::App* app, MapCommandOptions* options, int* exit_code) {
  CLI::App* cmd = app->add_subcommand(
      "map", "Fuse the scans, moved by their poses, into an OctoMap (.bt) and a cloud (.pcd)");
  map::MapOptions& m = options->map;
  cmd->add_option("input", options->input,
                  "folder with scans/ (store, simulate --3d), 3DTK scans, or a native log with SCAN records")
      ->required();
  cmd->add_option("--bt", m.bt_path, "OctoMap output (.bt)");
  cmd->add_option("--pcd", m.pcd_path, "registered cloud output (.pcd, binary_compressed)");
  cmd->add_option("--poses", options->poses_path, "TUM trajectory replacing the logged poses");
  cmd->add_option("--resolution", m.fusion.resolution, "leaf size [m]")
      ->check(PositiveReal())
      ->capture_default_str();
  cmd->add_option("--max-range", m.fusion.max_range, "ray length cap [m] (<0: none)")
      ->check(Real(-kNoUpperBound, kNoUpperBound))
      ->capture_default_str();
  cmd->add_option("--prob-hit", m.fusion.prob_hit, "P(occupied | hit)")
      ->check(Real(0.5, 1.0, Bounds::kOpen))
      ->capture_default_str();
  cmd->add_option("--prob-miss", m.fusion.prob_miss, "P(occupied | pass)")
      ->check(Real(0.0, 0.5, Bounds::kOpen))
      ->capture_default_str();
  cmd->add_option("--clamp-min", m.fusion.clamping_min, "lower clamping probability")
      ->check(Real(0.0, 0.5, Bounds::kOpen))
      ->capture_default_str();
  cmd->add_option("--clamp-max", m.fusion.clamping_max, "upper clamping probability")
      ->check(Real(0.5, 1.0, Bounds::kOpen))
      ->capture_default_str();
  cmd->add_option("--tile-bits", m.fusion.tile_bits, "tiles of 2^bits leaves a side")
      ->check(Integer(1, 15))
      ->capture_default_str();
  cmd->add_option("--pcd-voxel", m.pcd_voxel, "cloud voxel [m] (0: the resolution)")
      ->check(NonNegativeReal())
      ->capture_default_str();
  cmd->add_option("--memory-budget", options->memory_budget_mib,
                  "MiB for one tree; above it the .bt is written as tiles + index.json")
      ->check(PositiveReal())
      ->capture_default_str();
  cmd->add_option("--pcd-memory-budget", options->pcd_memory_mib,
                  "MiB of resident voxels of the .pcd, spilled to OUT.voxels/ beyond "
                  "(0: a quarter of --memory-budget)")
      ->check(NonNegativeReal())
      ->capture_default_str();
  cmd->add_option("--batch-points", m.batch_points, "points fused per parallel batch")
      ->check(Integer(1))
      ->capture_default_str();
  cmd->add_flag("-q,--quiet", options->quiet, "no summary on the terminal");
  cmd->add_flag("-v,--verbose", options->verbosity, "more log detail (repeatable)");
  cmd->callback([options, exit_code]() { *exit_code = RunMapCommand(*options); });
}

int RunMapCommand(const MapCommandOptions& options) {
  SetLogVerbosity(options.verbosity);
  SetQuietLogging(options.quiet);
  auto fail = [](const Status& status) {
    std::fprintf(stderr, "graphslam map: %s\n", status.ToString().c_str());
    return ExitCodeFor(status);
  };
  map::MapOptions map_options = options.map;
  if (!(options.memory_budget_mib > 0)) {
    std::fprintf(stderr, "graphslam map: --memory-budget must be > 0\n");
    return kExitUsage;
  }
  map_options.memory_budget_bytes = static_cast<int64_t>(options.memory_budget_mib * 1048576.0);
  if (!(options.pcd_memory_mib >= 0)) {
    std::fprintf(stderr, "graphslam map: --pcd-memory-budget must be >= 0\n");
    return kExitUsage;
  }
  map_options.pcd_memory_bytes = static_cast<int64_t>(options.pcd_memory_mib * 1048576.0);
  if (Status status = map_options.Validate(); !status.ok()) {
    std::fprintf(stderr, "graphslam map: %s\n", status.message().c_str());
    return kExitUsage;
  }
  if (Status status = CheckOutputPaths({{"--bt", map_options.bt_path},
                                        {"--pcd", map_options.pcd_path}});
      !status.ok())
    return fail(status);
  // A chunk store's scans: read under its shared lock (no writer meanwhile),
  // and only if they match the CRC32Cs of its manifest.
  storage::DirectoryLock lock;
  if (storage::IsChunkStore(options.input)) {
    StatusOr<storage::DirectoryLock> locked =
        storage::DirectoryLock::Acquire(options.input, storage::DirectoryLock::Mode::kShared);
    if (!locked.ok()) return fail(locked.status());
    lock = std::move(locked).value();
    if (Status status = storage::VerifyChunkStoreFiles(options.input, "scans/"); !status.ok())
      return fail(status);
  }
  StatusOr<std::unique_ptr<map::ScanSource>> source = OpenScanSource(options.input);
  if (!source.ok()) return fail(source.status());
  std::vector<core::Pose3> poses;
  if (!options.poses_path.empty()) {
    StatusOr<std::vector<core::Pose3>> read = ReadTumPoses(options.poses_path);
    if (!read.ok()) return fail(read.status());
    poses = std::move(read).value();
  }
  StatusOr<map::MapSummary> summary =
      map::BuildMap(map_options, **source, options.poses_path.empty() ? nullptr : &poses);
  if (!summary.ok()) return fail(summary.status());
  if (!options.quiet) {
    const map::MapSummary& s = *summary;
    if (map_options.bt_path.empty()) {
      // Nothing was fused (no .bt): no fusion time, so no rate.
      std::printf("Read %lld scans (%lld points).", static_cast<long long>(s.scans),
                  static_cast<long long>(s.points));
    } else {
      std::printf("Fused %lld scans (%lld points) at %.3f m in %.2f s (%.0f points/s, %lld tiles, "
                  "%.1f MiB of tree; peak %.1f MiB of tiles + codes, %lld tile spills).",
                  static_cast<long long>(s.scans), static_cast<long long>(s.points),
                  map_options.fusion.resolution, s.fusion_seconds, s.points_per_second,
                  static_cast<long long>(s.tiles), static_cast<double>(s.tree_bytes) / 1048576.0,
                  static_cast<double>(s.fusion_peak_bytes) / 1048576.0,
                  static_cast<long long>(s.tile_spills));
    }
    if (!map_options.bt_path.empty()) {
      if (s.tiled_output) {
        std::printf(" Over the memory budget: wrote tiles, index %s.", s.tiles_index.c_str());
      } else {
        std::printf(" Wrote %s (%lld occupied, %lld free leaves).", map_options.bt_path.c_str(),
                    static_cast<long long>(s.occupied_leaves), static_cast<long long>(s.free_leaves));
      }
    }
    if (!map_options.pcd_path.empty()) {
      std::printf(" Wrote %s (%lld points%s).", map_options.pcd_path.c_str(),
                  static_cast<long long>(s.pcd_points),
                  s.pcd_tile_spills > 0 ? ", voxel tiles spilled to disk" : "");
    }
    std::printf("\n");
  }
  return kExitOk;
}

}  // namespace graphslam::tools

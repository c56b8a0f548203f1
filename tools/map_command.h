// `graphslam map INPUT --bt OUT.bt --pcd OUT.pcd [--resolution R] ...`: fuses
// every scan of INPUT, moved by its pose, into an OctoMap and a registered
// cloud (tools/map_builder.h, docs/maps.md).
//
// INPUT is a folder holding scans/SCANS.json (a chunk store or a
// `simulate --3d --scans` output; docs/formats/scan_chunk.md), a 3DTK uos
// scan folder (scanNNN.3d + scanNNN.pose), or a native log whose SCAN
// records name .pcd files (storage/native_log_scans.h). --poses FILE.tum replaces each
// scan's logged pose by row `scan.pose` of FILE (the optimized trajectory).
//
// For batch jobs: OpenScanSource + ReadTumPoses + map::BuildMap are the
// library entry points; RunMapCommand is the CLI around them.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "core/se3.h"
#include "core/status.h"
#include "storage/scan_store.h"
#include "tools/cli_fwd.h"
#include "tools/map_builder.h"

namespace graphslam::tools {

struct MapCommandOptions {
  std::string input;
  std::string poses_path;  // --poses: TUM trajectory, row k = pose k
  map::MapOptions map;
  double memory_budget_mib = 4096.0;
  double pcd_memory_mib = 0.0;  // resident voxels of the .pcd; 0: memory_budget_mib / 4
  bool quiet = false;
  int verbosity = 0;  // -v, repeatable (GS_VLOG level)
};

// A folder with scans/SCANS.json, a native log with SCAN records, else a 3DTK
// folder. NotFound if none.
StatusOr<std::unique_ptr<map::ScanSource>> OpenScanSource(const std::string& input);

// TUM rows "stamp tx ty tz qx qy qz qw" (# comments, blank lines skipped), in
// file order. Corruption naming file:line.
StatusOr<std::vector<core::Pose3>> ReadTumPoses(const std::string& path);

void AddMapCommand(CLI::App* app, MapCommandOptions* options, int* exit_code);
int RunMapCommand(const MapCommandOptions& options);

}  // namespace graphslam::tools

// `graphslam simulate --3d --scans -o DIR`: the 3-D campus of tools/campus_3d.h
// seen by a vertically scanning laser, written as
//
//   DIR/scans/                the scans in chunks (docs/formats/scan_chunk.md;
//                             each scan's sensor_pose is the true pose)
//   DIR/ground_truth_3d.tum   the true sensor poses (TUM: k*dt tx ty tz qx qy qz qw,
//                             row k = pose k)
//   DIR/campus3d.json         the world: buildings (boxes), trees, ground slope
//
// These options hang on the existing `simulate` subcommand (--3d switches to
// them; --seed is shared with the 2-D simulator).
#pragma once

#include <string>

#include "tools/campus_3d.h"
#include "tools/cli_fwd.h"

namespace graphslam::tools {

struct Simulate3dOptions {
  bool enabled = false;  // --3d
  bool scans = false;    // --scans
  map::Campus3dOptions campus;
  double dt = 0.5;  // [s] between poses (TUM stamps)
};

// Adds --3d, --scans and the 3-D campus options to `simulate`.
void AddSimulate3dOptions(CLI::App* simulate, Simulate3dOptions* options);

// Simulates and writes DIR; returns the process exit code. `seed` is --seed.
int RunSimulate3dCommand(const std::string& output_dir, const Simulate3dOptions& options,
                         uint64_t seed, bool quiet);

}  // namespace graphslam::tools

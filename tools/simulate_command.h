// `graphslam simulate -o DIR ...`: a synthetic campus data set with ground
// truth (tools/campus_simulator.h), written as
//
//   DIR/log.graphslam              the measurements (native log,
//                                  docs/formats/native_log.md), or
//   DIR/graph.g2o                  with --format g2o (velocity motions become
//                                  EDGE_SE2, range-bearing EDGE_SE2_XY;
//                                  storage/g2o_writer.h)
//   DIR/ground_truth.tum           the true trajectory (TUM, stamps k * dt per run)
//   DIR/ground_truth_features.csv  the true landmarks (id,x,y,observations,excluded)
//
// DIR is created if missing; every file is written atomically. Bad options
// exit with kExitUsage before anything is written.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "tools/campus_simulator.h"
#include "tools/cli_fwd.h"
#include "tools/simulate_3d_command.h"

namespace graphslam::tools {

struct SimulateCommandOptions {
  std::string output_dir;         // -o
  std::string format = "native";  // native, g2o
  CampusSimulatorOptions simulator;
  std::vector<double> alpha;  // --alpha a1..a6: replaces simulator.noise.alpha when given
  std::vector<double> landmark_spacing;  // --landmark-spacing MIN MAX (m)
  bool quiet = false;
  int verbosity = 0;  // -v, repeatable (GS_VLOG level)
  Simulate3dOptions sim3d;  // --3d --scans (tools/simulate_3d_command.h)
  bool streaming = false;  // --streaming: tools/streaming_campus_simulator.h (native only)
  bool compress = false;   // --compress: with --streaming, log.graphslam.zst
};

// Registers the subcommand on `app`; the callback stores the exit code in *exit_code.
void AddSimulateCommand(CLI::App* app, SimulateCommandOptions* options, int* exit_code);

// Simulates and writes; returns the process exit code (tools/exit_codes.h).
int RunSimulateCommand(const SimulateCommandOptions& options);

}  // namespace graphslam::tools

// `graphslam evaluate --trajectory EST.tum --ground-truth GT.tum ...`: the
// accuracy of a solve against ground truth (tools/trajectory_metrics.h):
// trajectory position and heading RMSE after a rigid 2-D alignment, and, given
// features, the landmark RMSE both with the trajectory's alignment and with
// the features' own. The ground truth is either a TUM file (+ a features CSV,
// e.g. from `graphslam simulate`) or an MRCLAM folder (--mrclam DIR --robot N:
// RobotN_Groundtruth.dat and Landmark_Groundtruth.dat, whose subject numbers
// are the solver's MRCLAM feature ids). Prints the figures; --report writes
// them as JSON, atomically.
#pragma once

#include <string>

#include "tools/cli_fwd.h"

namespace graphslam::tools {

struct EvaluateCommandOptions {
  std::string trajectory;             // estimated TUM
  std::string ground_truth;           // ground-truth trajectory (TUM or KITTI)
  std::string ground_truth_format = "auto";  // auto, tum, kitti
  std::string ground_truth_times;     // KITTI: times file (else stamps = frame index)
  std::string features;               // estimated features CSV
  std::string ground_truth_features;  // ground-truth features CSV
  std::string mrclam;                 // MRCLAM folder (instead of the two ground truths)
  int robot = 1;
  std::string report;                 // JSON
  double max_time_difference = -1.0;  // s; < 0: automatic
  bool quiet = false;
  int verbosity = 0;  // -v, repeatable (GS_VLOG level)
};

// Registers the subcommand on `app`; the callback stores the exit code in *exit_code.
void AddEvaluateCommand(CLI::App* app, EvaluateCommandOptions* options, int* exit_code);

// Evaluates; returns the process exit code (tools/exit_codes.h).
int RunEvaluateCommand(const EvaluateCommandOptions& options);

}  // namespace graphslam::tools

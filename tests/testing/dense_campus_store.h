// The dense GPS campus of `graphslam benchmark` (speed 8 m/s, 8 m sensor
// range, landmarks 0.015-0.025 m apart, GPS every 50 poses, ~360
// observations per pose at 10^6 features over 1 000 poses) simulated as a
// native log and ingested into a chunk store, for the initialization tests.
#pragma once

#include <cstdint>
#include <string>

#include "tools/exit_codes.h"
#include "tools/ingest_command.h"
#include "tools/simulate_command.h"

namespace graphslam::testing {

// Simulates into `dir`/sim`name` and ingests into `dir`/store`name`; returns
// the store's path, or "" when a command failed.
inline std::string SimulateDenseCampusStore(const std::string& dir, const std::string& name,
                                            int64_t poses, int runs, int64_t features) {
  tools::SimulateCommandOptions simulate;
  simulate.output_dir = dir + "/sim" + name;
  simulate.streaming = true;
  simulate.simulator.features = features;
  simulate.simulator.poses = poses;
  simulate.simulator.runs = runs;
  simulate.simulator.gps_every = 50;
  simulate.simulator.speed = 8.0;
  simulate.simulator.sensor_range = 8.0;
  simulate.landmark_spacing = {0.015, 0.025};
  simulate.quiet = true;
  if (tools::RunSimulateCommand(simulate) != tools::kExitOk) return "";
  tools::IngestCommandOptions ingest;
  ingest.input = simulate.output_dir + "/log.graphslam";
  ingest.output_dir = dir + "/store" + name;
  ingest.quiet = true;
  if (tools::RunIngestCommand(ingest) != tools::kExitOk) return "";
  return ingest.output_dir;
}

}  // namespace graphslam::testing

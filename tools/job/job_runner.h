// The batch job runner behind `graphslam run JOB.yaml [--resume]`
// (docs/jobs.md): stages run in order, each a function that reads what the
// previous stage left in OUTPUT/.job/ and writes its own result there
// atomically, then the stage is recorded in OUTPUT/.job/state.json
// (job_state.h). Every stage reads its input back from disk, also in an
// uninterrupted run, so a resumed job computes from exactly the same bytes
// (native logs and JSON keep doubles with round-trip precision).
//
//   ingest      read / simulate the runs, attach GPS, merge, find components
//               -> .job/ingested.graphslam, .job/runs.json
//   initialize  per component: Table 1 guess, progressive initialization
//               -> .job/initialized.graphslam
//   associate   known correspondences (shared landmark ids): recorded only
//   optimize    per component: Levenberg-Marquardt with a solver checkpoint
//               after every iteration (.job/optimize_c<k>.checkpoint.json) and
//               the chi2 history (.job/optimize_c<k>.history.json)
//               -> .job/optimized.graphslam, .job/optimize.json
//   map         3-D map fusion of the runs' scans (none yet: logged)
//   export      OUTPUT/trajectories/<run>.tum (and <run>_groundtruth.tum),
//               map.runs.json, features.csv, graph.g2o,
//               report.json, report.html (each atomically)
//
// --resume skips the stages state.json lists and continues the optimize
// stage from the last checkpoint of each component. Without --resume the
// .job folder is started afresh; the final outputs of an earlier job in the
// same folder are only replaced, atomically, by the export stage.
//
// THREAD SAFETY: one job per process (TBB's global thread limit).
// ALLOCATION: O(problem).
#pragma once

#include <string>

#include "core/status.h"

namespace graphslam::tools::job {

struct RunJobOptions {
  std::string job_path;
  std::string output;  // replaces the job file's `output:` when not empty
  bool resume = false;
  bool quiet = false;
  int verbosity = 0;
};

// Runs the job; returns the first error (with file:line for bad input).
Status RunJob(const RunJobOptions& options);

}  // namespace graphslam::tools::job

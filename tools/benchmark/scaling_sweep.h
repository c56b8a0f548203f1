// RunScalingSweep: the scaling benchmark as a job (`graphslam benchmark`).
//
// For each size N (features) in increasing order, in one proportion
// (poses = N · poses_per_feature, the landmark density and sensor range of the
// 10^8-feature campus), three steps run as child processes of this binary
// (tools/benchmark/child_process.h), each with default options:
//
//   1. simulate   a streamed, zstd-compressed campus log of N features
//   2. ingest     the log into a chunk store
//   3. solve      the store to convergence (`graphslam solve STORE`, with
//                 --initialization only if one is given)
//
// and one row records what each cost (wall, CPU, peak RSS), the store's
// bytes, the iterations, seconds per iteration and chi2 per degree of freedom
// (about 1 at the optimum of simulated data with the true noise).
//
// Folder layout of OUT:
//   scaling.csv, scaling.html   current results (rewritten after every size)
//   .benchmark/state.json       the rows done and the proportion, sealed
//                               (storage/checksummed_json.h)
//   .benchmark/n<N>/            a size's work: logs of its steps (the log and
//                               the store are removed when the size is done,
//                               unless keep_stores)
// OUT is locked for the whole sweep (storage/directory_lock.h); a folder that
// is neither missing, empty nor a benchmark folder is refused.
//
// Resume: with `resume`, sizes recorded in state.json are kept and the sweep
// goes on with the next one; a size interrupted mid-way starts over (its
// steps are minutes at most at 10^8). Without it, state.json is started
// afresh. A state.json of another proportion is refused.
//
// THREAD SAFETY: one sweep per folder. ALLOCATION: the rows.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/status.h"

namespace graphslam::tools::benchmark {

struct ScalingProportion {
  double poses_per_feature = 0.01;
  int runs = 2;
  int gps_every = 50;
  double speed = 8.0;               // m/s
  double landmark_spacing_min = 0.015;  // m
  double landmark_spacing_max = 0.025;  // m
  double sensor_range = 8.0;        // m
  uint32_t seed = 1;
  // The solve's --initialization; "" (the default): the solve's own default.
  std::string initialization;
};

struct ScalingSweepOptions {
  std::string output;
  std::vector<int64_t> features;  // sizes
  ScalingProportion proportion;
  bool keep_stores = false;
  bool resume = false;
  bool quiet = false;
};

struct ScalingRow {
  int64_t features = 0;
  int64_t poses = 0;
  int64_t observations = 0;
  double simulate_seconds = 0;
  double ingest_seconds = 0;
  double solve_seconds = 0;
  double ingest_cpu_seconds = 0;
  double solve_cpu_seconds = 0;
  int64_t ingest_peak_rss_bytes = 0;
  int64_t solve_peak_rss_bytes = 0;
  int64_t store_bytes = 0;
  int iterations = 0;
  double seconds_per_iteration = 0;
  double chi2_per_dof = 0;
  std::string termination;

  double end_to_end_seconds() const { return ingest_seconds + solve_seconds; }
};

// The poses of size `features` in `proportion` (at least 2 per run).
int64_t PosesFor(const ScalingProportion& proportion, int64_t features);

// Runs the sweep; `*rows` gets every size's row, resumed ones included.
[[nodiscard]] Status RunScalingSweep(const ScalingSweepOptions& options,
                                     std::vector<ScalingRow>* rows);

}  // namespace graphslam::tools::benchmark

// What the two initializers that optimize growing prefixes of the trajectory
// in time order share: progressive (progressive_initialization.h, every
// prefix whole) and incremental (incremental_initialization.h, a window of
// recent poses of each prefix). Both cut the same schedule,
//   T_0 = first_poses,  T_{k+1} ~ growth T_k, at most max_new_poses more,
//   backing off towards min_new_poses after unsettled stages,
// solve each stage for at most max_iterations_per_stage LM iterations on
// chunks of max_observations_per_chunk observations, and open their run
// alike (BeginPrefixStages) and time their stages on one clock. Each initializer's options derive from
// PrefixStageOptions, add its own and validate them all.
//
// THREAD SAFETY: pure. ALLOCATION: none.
#pragma once

#include <chrono>
#include <cstdint>

#include "core/graphslam_solver.h"
#include "core/problem.h"
#include "core/status.h"

namespace graphslam::partition {

struct PrefixStageOptions {
  bool enabled = true;
  // Poses of the first stage (T_0).
  int64_t first_poses = 100;
  // Prefix growth factor between stages (> 1).
  double growth = 2.0;
  // At most this many new poses per stage (progressive: 0 is no cap).
  // Odometry drift grows with the length of the chained segment, so late
  // stages must stay short.
  int64_t max_new_poses = 500;
  // The fewest new poses a stage adds after stages that did not converge.
  int64_t min_new_poses = 25;
  // LM iterations per stage (each stage solve).
  int max_iterations_per_stage = 10;
  // Chunking of each stage's observations.
  int64_t max_observations_per_chunk = 4096;
};

// The clock of the summaries' stage and run times.
using StageClock = std::chrono::steady_clock;
inline double StageSecondsSince(StageClock::time_point start) {
  return std::chrono::duration<double>(StageClock::now() - start).count();
}

// The opening of a run: *summary reset, `options` (its Validate) and `base`
// valid, then, when enabled, `check_problem(problem)` and summary->ran set.
// Returns whether there are stages to run (enabled and some pose).
template <class Options, class Summary, class CheckProblem>
StatusOr<bool> BeginPrefixStages(const Options& options, const core::SolverOptions& base,
                                 const core::Problem2d& problem, Summary* summary,
                                 CheckProblem&& check_problem) {
  *summary = Summary();
  GS_RETURN_IF_ERROR(options.Validate());
  GS_RETURN_IF_ERROR(base.Validate());
  if (!options.enabled) return false;
  GS_RETURN_IF_ERROR(check_problem(problem));
  summary->ran = true;
  return problem.num_poses() > 0;
}

}  // namespace graphslam::partition

// What progressive and incremental initialization
// (partition/initialization/progressive_initialization.h, partition/initialization/incremental_initialization.h)
// both do before their stages: check that the per-pose and per-feature
// arrays match the poses and features (a Status for the caller, where
// core::ValidateProblem would stop on its invariant), and derive the options
// of a stage's solve from the caller's: the stage's iteration cap and none of
// the caller's callbacks, checkpoint or resume state, which belong to the
// final solve.
//
// THREAD SAFETY: pure functions. ALLOCATION: the message of an error.
#pragma once

#include <string>

#include "core/graphslam_solver.h"
#include "core/problem.h"
#include "core/status.h"

namespace graphslam::partition::internal {

inline Status CheckPerElementArrays(const core::Problem2d& problem) {
  const size_t n = problem.poses.size(), m = problem.features.size();
  if (problem.pose_ids.size() == n && problem.pose_fixed.size() == n &&
      problem.pose_initialized.size() == n && problem.pose_lines.size() == n &&
      problem.pose_stamps.size() == n && problem.feature_ids.size() == m &&
      problem.feature_initialized.size() == m)
    return Status::Ok();
  return Status::InvalidArgument(
      (problem.source.empty() ? std::string("<input>") : problem.source) +
      ": per-pose or per-feature arrays differ in length from poses / features");
}

inline core::SolverOptions StageSolverOptions(const core::SolverOptions& base,
                                              int max_iterations_per_stage) {
  core::SolverOptions stage = base;
  stage.max_iterations = max_iterations_per_stage;
  stage.progress = nullptr;
  stage.iteration_callback = nullptr;
  stage.checkpoint_callback = nullptr;
  stage.resume_from = nullptr;
  stage.candidate_store = nullptr;
  return stage;
}

}  // namespace graphslam::partition::internal

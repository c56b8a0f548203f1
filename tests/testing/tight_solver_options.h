// Solver options for tests that compare against an optimum: CHOLMOD (exact
// steps) and tolerances far below the test's own tolerance, so a test
// failure means a different optimum, not an early stop.
#pragma once

#include "core/graphslam_solver.h"

namespace graphslam::testing {

inline core::SolverOptions TightCholmodSolverOptions() {
  core::SolverOptions options;
  options.linear_solver = core::LinearSolverType::kCholmod;
  options.function_tolerance = 1e-14;
  options.parameter_tolerance = 1e-14;
  options.gradient_tolerance = 1e-12;
  options.max_iterations = 200;
  return options;
}

}  // namespace graphslam::testing

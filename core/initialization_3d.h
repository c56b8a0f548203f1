// Initial guess and checks of a Problem3d (the 3-D counterpart of
// core/initialization.h, paper Table 1 generalized to a pose graph).
//
// Poses. The guess is chained along the relative-pose edges by a breadth-first
// search, x_to = x_from z, x_from = x_to z^-1, started from every pose whose
// guess came from the input, or from pose 0 at the identity when none did.
// An input whose guesses are ALL the identity while some edge is not (a file
// that lists vertices without estimates) is treated as having no guess: every
// pose but the seed is re-chained. A pose the chain does not reach starts at
// its GPS fix, else at the identity.
//
// Features without a guess are placed by their first observation,
// m = x z (core/point_3d_observation_model.h).
//
// Checks (before anything is modified): indices in range, information
// matrices finite, symmetric and positive definite, every pose connected to an
// anchor (fixed pose, pose 0, or a GPS fix) through edges or shared features.
// Errors are InvalidArgument naming the file and line.
//
// THREAD SAFETY: mutates *problem only. ALLOCATION: O(poses + constraints).
#pragma once

#include "core/problem_3d.h"
#include "core/status.h"

namespace graphslam::core {

Status ValidateProblem3d(const Problem3d& problem);

// Validates, then fills in the missing guesses (marking them initialized).
Status InitializeProblem3d(Problem3d* problem);

}  // namespace graphslam::core

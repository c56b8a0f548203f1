// PcgSolverState: what the PCG path of ReducedSystemSolver
// (core/reduced_system_solver.h) carries from one Levenberg-Marquardt
// iteration to the next, so that a solve resumed from a checkpoint takes the
// very steps of the uninterrupted one (bit for bit):
//
//   eta_k           the forcing term of the last solve (Eisenstat-Walker)
//   |rhs_{k-1}|     the reduced gradient norm of the last accepted linearization,
//                   the denominator of the next eta, and |rhs| of the last solve
//   x_prev          the last solution, the next warm start
//   the forest      the subgraph preconditioner's spanning forest, chosen once
//                   from the values of the first linearization (a forest chosen
//                   again at the resumed state would differ)
//
// Stored in BasicSolverCheckpoint::pcg (core/graphslam_solver.h) and on disk as
// the checkpoint's "pcg" object (docs/formats/solver_checkpoint.md). A default
// (present = false) state is a fresh solver: CHOLMOD runs, and checkpoints
// written before the state existed, resume with it.
//
// THREAD SAFETY: a plain value. ALLOCATION: O(unknowns) doubles and
// O(pose blocks) ints.
#pragma once

#include <vector>

namespace graphslam::core {

struct PcgSolverState {
  bool present = false;  // false: nothing to restore (fresh solver)
  double eta = 0.0;
  double previous_rhs_norm = -1.0;  // |rhs| of the last accepted linearization (-1: none)
  double last_rhs_norm = -1.0;      // |rhs| of the last solve (-1: none)
  bool have_previous = false;       // an accepted step awaits its eta update
  std::vector<double> previous_x;   // empty: no warm start yet
  // Subgraph forest (core/subgraph_preconditioner.h); empty when not chosen
  // yet or when another preconditioner runs. forest_order: block rows in
  // elimination (post-)order; forest_parent[i]: parent block row of block row
  // i, -1 for a root. Each tree edge must be a block of the reduced matrix.
  std::vector<int> forest_order;
  std::vector<int> forest_parent;
};

}  // namespace graphslam::core

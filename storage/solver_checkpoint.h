// Solver checkpoints on disk: the state SolveGraphSlam needs to continue an
// interrupted solve exactly (core::SolverCheckpoint), as one JSON document
// (docs/formats/solver_checkpoint.md).
//
// Durability: written through WriteFileAtomically (temp file, fsync, rename,
// directory fsync), so the previous checkpoint stays readable until the new one
// is complete — a kill -9 at any moment leaves one good checkpoint. Doubles are
// written with round-trip precision, so a resumed solve is bit-identical.
//
// THREAD SAFETY: plain functions. ALLOCATION: O(poses + features).
#pragma once

#include <string>

#include "core/graphslam_solver.h"
#include "core/status.h"
#include "storage/env.h"

namespace graphslam::storage {

inline constexpr const char* kSolverCheckpointFormat = "graphslam-solver-checkpoint";
inline constexpr int kSolverCheckpointVersion = 1;

// `input` names the problem the checkpoint belongs to; ReadSolverCheckpoint
// rejects a checkpoint of another input.
Status WriteSolverCheckpoint(Env* env, const std::string& path, const std::string& input,
                             const core::SolverCheckpoint& checkpoint);

// Reads and validates a checkpoint: format, version (NotSupported if newer),
// input, sizes, finite numbers. Errors name the file and the field.
StatusOr<core::SolverCheckpoint> ReadSolverCheckpoint(const std::string& path,
                                                      const std::string& input);

}  // namespace graphslam::storage

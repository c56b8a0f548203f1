// Solver checkpoints on disk: the state SolveGraphSlam (core::SolverCheckpoint)
// or SolveGraphSlam3d (core::SolverCheckpoint3d) needs to continue an
// interrupted solve exactly, as one JSON document
// (docs/formats/solver_checkpoint.md). 3-D poses are x y z qx qy qz qw.
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
#include "core/graphslam_solver_3d.h"
#include "core/status.h"
#include "storage/env.h"

namespace graphslam::storage {

inline constexpr const char* kSolverCheckpointFormat = "graphslam-solver-checkpoint";
// Version 2 added the optional "pcg" object (core/pcg_solver_state.h); a
// checkpoint without it is still written as version 1, and both are read.
// Version 3: the per-feature arrays are in a binary file beside the JSON
// (below), named by its "features_file". Version 4: the poses and the PCG
// state too, in a state file (storage/solver_state_file.h) named by its
// "state_file". Versions 1-4 are read; a version-3 build refuses a version-4
// checkpoint with NotSupported.
inline constexpr int kSolverCheckpointVersion = 4;

// `input` names the problem the checkpoint belongs to; ReadSolverCheckpoint
// rejects a checkpoint of another input.
Status WriteSolverCheckpoint(Env* env, const std::string& path, const std::string& input,
                             const core::SolverCheckpoint& checkpoint);

// The same with the feature estimates and flags in a binary file beside the
// JSON instead of JSON arrays (the streaming solve: 18 bytes per feature, no
// text to format or parse): "<path>.features.<iterations>.bin", a feature
// record file of kind 2 (storage/feature_record_file.h), and the poses and
// PCG state in "<path>.state.<iterations>.bin" (kind 3,
// storage/solver_state_file.h: no JSON tree of 10^6 poses), both written
// atomically before the JSON (version 4) that names them; once the JSON is
// durable, the files of other generations are removed. A kill at any point
// leaves the previous JSON and the generation it names.
Status WriteSolverCheckpointWithFeatureFile(Env* env, const std::string& path,
                                            const std::string& input,
                                            const core::SolverCheckpoint& checkpoint);
Status WriteSolverCheckpoint(Env* env, const std::string& path, const std::string& input,
                             const core::SolverCheckpoint3d& checkpoint);

// Reads and validates a checkpoint: format, version (NotSupported if newer),
// input, dimension, sizes, finite numbers. Errors name the file and the field
// (for the feature file: its name and the byte offset of the bad record).
StatusOr<core::SolverCheckpoint> ReadSolverCheckpoint(const std::string& path,
                                                      const std::string& input);
StatusOr<core::SolverCheckpoint3d> ReadSolverCheckpoint3d(const std::string& path,
                                                          const std::string& input);

}  // namespace graphslam::storage

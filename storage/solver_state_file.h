// Solver state files: the poses and the PCG state (core/pcg_solver_state.h)
// of a version-4 checkpoint (storage/solver_checkpoint.h), as framed,
// checksummed binary records beside the checkpoint's JSON instead of JSON
// arrays (docs/formats/feature_state.md, kind 3).
//
// Why: at 10^6 poses the JSON of these arrays (3*10^6 pose values, the
// 3*10^6-value warm start x_prev, the 2*10^6-entry forest) is ~131 MB of text
// built through an nlohmann tree (~16 B per number) and dumped into a string
// (and copied once more): an RSS spike of ~400 MB at every iteration of the
// 10^8 streaming solve. Here the arrays are encoded into records of at most
// 65536 elements and appended through a 1 MiB buffer: O(1) extra memory.
//
//   file     := header (kind 3, dimension 2) summary record* footer
//   summary  := data record: section:u8 = 0, poses:u64, pcg_present:u8,
//               eta:f64, previous_rhs_norm:f64, last_rhs_norm:f64,
//               have_previous:u8, previous_x:u64, forest:u64
//   record   := data record: section:u8 (1 poses, 2 previous_x,
//               3 forest_order, 4 forest_parent), first:u64, count:u32,
//               values (poses: f64[3 count] x y theta; previous_x: f64[count];
//               forest: i32[count])
//   footer   := records, items = poses + previous_x + 2 forest
//
// Sections come in order 1..4, each contiguous from element 0 and complete.
// Doubles are stored as their bits (a resumed solve is bit-identical).
// Errors are Corruption "FILE: offset N: what" with the byte offset of the
// bad record; a missing file is NotFound naming it.
//
// THREAD SAFETY: plain functions. ALLOCATION: the result (reading) and one
// 1 MiB buffer (writing).
#pragma once

#include <string>
#include <vector>

#include "core/pcg_solver_state.h"
#include "core/se2.h"
#include "core/status.h"
#include "storage/env.h"

namespace graphslam::storage {

// Writes `path` atomically (temp file, fsync, rename, directory fsync).
[[nodiscard]] Status WriteSolverStateFile(Env* env, const std::string& path,
                                          const std::vector<core::Pose2>& poses,
                                          const core::PcgSolverState& pcg);

// Reads and validates `path` into *poses and *pcg (pcg->present as written).
[[nodiscard]] Status ReadSolverStateFile(const std::string& path, std::vector<core::Pose2>* poses,
                                         core::PcgSolverState* pcg);

}  // namespace graphslam::storage

// Checks a core::Problem2d before a writer turns it into bytes (bad input
// is rejected before anything is written): array sizes agree,
// every index is in range, ids are unique, values are finite.
//
// THREAD SAFETY: pure. ALLOCATION: O(poses + features) for the id sets.
#pragma once

#include "core/problem.h"
#include "core/status.h"

namespace graphslam::storage::internal {

// InvalidArgument naming the element, e.g. "relative_poses[3].to is 12;
// expected an index below 10 (num_poses)". With `shared_id_space` (g2o), a
// pose id equal to a feature id is an error too.
Status ValidateProblemForWriting(const core::Problem2d& problem, bool shared_id_space);

}  // namespace graphslam::storage::internal

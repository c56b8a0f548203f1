// Writes the features (the map) of a core::Problem2d or core::Problem3d as
// CSV, through WriteFileAtomically:
//
//   id,x,y,observations,excluded          (2-D)
//   id,x,y,z,observations,excluded        (3-D)
//   5,11.634,-3.202,37,0
//
// one row per feature in index order: its input id, its position, how many
// observations name it, and 1 if `excluded` marks it (e.g. features the
// solver dropped as unconstrained), else 0. Numbers are "%.17g". Both
// dimensions are one template over the problem in the .cc file.
//
// THREAD SAFETY: reentrant. ALLOCATION: O(features) for the counts.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/problem.h"
#include "core/problem_3d.h"
#include "core/status.h"
#include "storage/env.h"

namespace graphslam::storage {

// `excluded`, if given, has one entry per feature (else InvalidArgument,
// before anything is written); so does every observation's feature index.
// `env` defaults to Env::Default().
[[nodiscard]] Status WriteFeaturesCsv(const core::Problem2d& problem, const std::string& path,
                                      const std::vector<uint8_t>* excluded = nullptr,
                                      Env* env = nullptr);
[[nodiscard]] Status WriteFeaturesCsv(const core::Problem3d& problem, const std::string& path,
                                      const std::vector<uint8_t>* excluded = nullptr,
                                      Env* env = nullptr);

}  // namespace graphslam::storage

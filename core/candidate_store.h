// CandidateStore: where a streaming solve keeps the candidate feature
// estimates of one Levenberg-Marquardt step between the recover pass, which
// computes them chunk by chunk, and the accept / reject decision, which comes
// only after the whole pass (the candidate chi2 is a sum over every chunk).
//
// In memory that is one estimate per feature (16 bytes in 2-D: ~0.7 GB at
// 4.4*10^7 observed features). A store written to disk
// (storage/candidate_file.h) keeps it off the heap: the pass appends each
// chunk's candidates in chunk order (Append, serial), and an accepted step
// streams them back (ForEach) into the estimates. The values are copied
// bytes, so the solve is bit-identical to the in-memory one.
//
//   Begin()   a new step: forget the previous candidates
//   Append()  one chunk's features and their candidates (chunk order)
//   Finish()  the pass is complete
//   ForEach() every (feature, candidate) of the last finished step, in the
//             order appended
//
// THREAD SAFETY: one caller at a time (the passes call Append from their
// serial merge stage). ALLOCATION: the implementation's buffers.
#pragma once

#include <cstdint>
#include <functional>

#include "core/se2.h"
#include "core/status.h"

namespace graphslam::core {

template <class Point>
class BasicCandidateStore {
 public:
  virtual ~BasicCandidateStore() = default;
  [[nodiscard]] virtual Status Begin() = 0;
  [[nodiscard]] virtual Status Append(int64_t chunk, const int32_t* features, const Point* values,
                                      int64_t count) = 0;
  [[nodiscard]] virtual Status Finish() = 0;
  [[nodiscard]] virtual Status ForEach(
      const std::function<void(int32_t feature, const Point& value)>& visit) = 0;
};

using CandidateStore = BasicCandidateStore<Point2>;

}  // namespace graphslam::core

// The Table 1 initialization (core/initialization.h) of a streamed input in
// O(poses) memory: pass 1 of the ingest (partition/ingest/streaming_ingest.h) feeds
// every observation once, in input order; afterwards Initialize gives the
// pose-only problem the guesses and the connectivity verdict that
// core::InitializeProblem gives with all observations in memory.
//
// Table 1 needs two things of the observations:
//   - feature placement: an uninitialized feature is placed by its FIRST
//     observation in input order, m_f = x_p (+) z, from the initialized pose
//     guess of p. Pose guesses do not depend on observations (they chain
//     odometry, motions, GPS and input guesses), so the placement can wait
//     until after the poses are initialized;
//   - connectivity: every pose joined to an anchor through constraints or
//     shared features. Observations of a feature f joining two pose
//     components not yet joined (union-find over poses) are the only ones
//     that change the verdict: at most poses - 1 of them ("joining").
//
// So pass 1 appends the first sight of every feature to a scratch file
// (WORK/first_sight.bin, spill frames of 4096 observations,
// partition/ingest/spill_frames.h: ~4x smaller than raw records) and keeps only the joining observations in memory.
// Initialize then
//   1. reads the file once: checks every first sight (core::CheckObservation)
//      and keeps the first sights of the features that have joining
//      observations (a sorted list of at most poses - 1 features);
//   2. runs core::InitializeProblem on the pose-only problem plus those first
//      sights and the joining observations (first sights first: each feature
//      is placed by its first sight), with the problem's features cut down
//      to the joining ones (renumbered; the others have no observation
//      there, so its union-find and flags stay O(poses)), which validates,
//      initializes the poses, checks connectivity exactly as with all
//      observations (a feature seen from one pose component joins nothing),
//      and places those features;
//   3. reads the file again, placing every other uninitialized feature by its
//      first sight (core::PlaceFeature), then removes the file.
// The guesses are bit for bit InitializeProblem's on every observation
// (tested; the store's problem.graphslam is unchanged byte for byte).
//
// Which observation joins is decided with the FeatureIndex (external_bucketing.h)
// of pass 1, before it counts the observation: count 0 is the first sight,
// and the lowest pose seen so far stands for the feature's component (every
// pose that observed f is in one component: the first sight's pose, and each
// later pose was joined to it or already was), so no per-feature anchor is
// kept here.
//
// Per feature this holds nothing in memory (the disk holds 72 B per observed
// feature until Initialize ends). Errors: the checks of InitializeProblem,
// IOError naming the scratch file. One difference in what is reported first
// when an input has several errors: the first sights are checked before the
// pose constraints; the readers reject a non-positive-definite information
// matrix while parsing, so a valid log never reaches either check.
//
// THREAD SAFETY: one thread. ALLOCATION: O(poses) (union-find, joining
// observations) + 4096 observations of I/O buffer, + O(joining features) in
// Initialize.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/problem.h"
#include "core/status.h"
#include "partition/ingest/external_bucketing.h"
#include "partition/ingest/spill_frames.h"
#include "storage/env.h"

namespace graphslam::partition {

inline constexpr const char* kFirstSightScratchName = "first_sight.bin";

class FirstSightInitialization {
 public:
  // `scratch_path`: the file to write (truncated on the first Add); its folder
  // must exist.
  explicit FirstSightInitialization(std::string scratch_path);
  // Removes the scratch file (it is never an output).
  ~FirstSightInitialization();
  FirstSightInitialization(const FirstSightInitialization&) = delete;
  FirstSightInitialization& operator=(const FirstSightInitialization&) = delete;

  // Feeds `observation`; `index` must not have counted it yet (call before
  // index.Add(observation)). Errors: IOError writing the scratch file.
  [[nodiscard]] Status Add(const core::Observation& observation, const FeatureIndex& index);

  // Initializes the pose-only *problem (no observations; poses and features
  // of the whole input) as described above. Call once, after the last Add.
  [[nodiscard]] Status Initialize(core::Problem2d* problem);

  int64_t first_sights() const { return first_sights_; }
  const std::vector<core::Observation>& joining() const { return joining_; }

 private:
  int32_t Find(int32_t pose);
  Status Flush();
  // Calls `visit` for every first sight in the scratch file, in input order.
  template <typename Visit>
  Status ReadBack(const Visit& visit) const;

  static constexpr size_t kBlock = 4096;
  std::string path_;
  std::unique_ptr<storage::WritableFile> file_;
  SpillFrameEncoder encoder_{1};  // the file is spill frames (docs/formats/spill_bucket.md)
  std::vector<char> frame_;
  std::vector<core::Observation> buffer_;   // first sights not yet written
  int64_t first_sights_ = 0;
  std::vector<int32_t> parent_;             // union-find over poses
  std::vector<core::Observation> joining_;  // in input order, <= poses - 1
};

}  // namespace graphslam::partition

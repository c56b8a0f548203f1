#include "partition/initialization/sampled_incremental_initialization.h"

#include <algorithm>
#include <chrono>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "core/chunk_feature_runs.h"
#include "core/internal/ordered_chunk_pipeline.h"
#include "partition/initialization/internal/stage_setup.h"
#include "partition/initialization/pose_graph_initialization.h"

namespace graphslam::partition {
namespace {

// The sub-problem: every pose of `problem` (copied: the sub-problem's
// estimates replace them only at the end), no constraint (PoseConstraintLoan
// lends them) and no feature yet (the pass adds the sampled ones).
core::Problem2d PoseSubProblem(const core::Problem2d& problem) {
  core::Problem2d sub;
  sub.source = problem.source;
  sub.poses = problem.poses;
  sub.pose_fixed = problem.pose_fixed;
  sub.pose_initialized = problem.pose_initialized;
  return sub;
}

// Lends `problem`'s pose constraints and per-pose ids, lines and stamps to
// the sub-problem for its lifetime, moved rather than copied (10^6 poses'
// motions alone are ~110 MB); the sub-problem's solves only read them.
class PoseConstraintLoan {
 public:
  PoseConstraintLoan(core::Problem2d* problem, core::Problem2d* sub)
      : problem_(problem), sub_(sub) {
    Swap();
  }
  ~PoseConstraintLoan() { Swap(); }
  PoseConstraintLoan(const PoseConstraintLoan&) = delete;
  PoseConstraintLoan& operator=(const PoseConstraintLoan&) = delete;

 private:
  void Swap() {
    std::swap(problem_->pose_ids, sub_->pose_ids);
    std::swap(problem_->pose_lines, sub_->pose_lines);
    std::swap(problem_->pose_stamps, sub_->pose_stamps);
    std::swap(problem_->relative_poses, sub_->relative_poses);
    std::swap(problem_->motions, sub_->motions);
    std::swap(problem_->gps, sub_->gps);
    std::swap(problem_->pose_range_bearings, sub_->pose_range_bearings);
  }
  core::Problem2d* problem_;
  core::Problem2d* sub_;
};

// The sample's observations as chunks for its own solve, read in place:
// they are grouped by feature, features ascending (the order the pass
// gathered them in), so a chunk is a run of consecutive features holding at
// most max_observations_per_chunk observations (a larger feature alone).
// A copy cut by InMemoryChunkSource would double the sample's largest part.
class SampleChunkSource : public core::ChunkSource {
 public:
  SampleChunkSource(const CompactObservations& observations, int64_t per_chunk)
      : observations_(observations) {
    const int64_t m = static_cast<int64_t>(observations.size());
    starts_.push_back(0);
    int64_t feature_start = 0;  // of the feature being added
    for (int64_t i = 1; i <= m; ++i) {
      if (i < m && observations.feature(i) == observations.feature(i - 1)) continue;
      // Its observations are [feature_start, i): it opens a new chunk when
      // the current one holds others and would exceed the budget with it.
      if (feature_start > starts_.back() && i - starts_.back() > per_chunk)
        starts_.push_back(feature_start);
      feature_start = i;
    }
    if (m > 0) starts_.push_back(m);
  }

  int64_t NumChunks() const override { return static_cast<int64_t>(starts_.size()) - 1; }

  Status Load(int64_t index, core::ObservationChunk* chunk) const override {
    if (index < 0 || index >= NumChunks())
      return Status::InvalidArgument("sample chunk " + std::to_string(index) +
                                     " out of range; expected 0.." +
                                     std::to_string(NumChunks() - 1));
    chunk->Clear();
    chunk->index = index;
    chunk->observations.reserve(static_cast<size_t>(starts_[index + 1] - starts_[index]));
    for (int64_t k = starts_[index]; k < starts_[index + 1]; ++k)
      chunk->observations.push_back(observations_[k]);
    core::IndexFeatureRuns(chunk);
    return Status::Ok();
  }

 private:
  const CompactObservations& observations_;
  std::vector<int64_t> starts_;  // chunk k: observations [starts_[k], starts_[k + 1])
};

// The whole problem's feature estimates are dead from the sampling pass to
// step 4, which places every observed feature from first sight: only the
// unobserved ones' guesses (features of no chunk; none in a store the ingest
// wrote) must survive. Holding those alone frees 16 bytes per feature for
// the stages and the sample's solve.
class UnobservedGuesses {
 public:
  // Keeps the guesses of the features not `observed`, then frees
  // problem->features (num_features() is 0 until Restore).
  UnobservedGuesses(const std::vector<bool>& observed, core::Problem2d* problem)
      : problem_(problem), count_(problem->features.size()) {
    for (size_t f = 0; f < count_; ++f)
      if (!observed[f]) guesses_.emplace_back(static_cast<int32_t>(f), problem->features[f]);
    std::vector<core::Point2>().swap(problem->features);
  }
  // An error on the way still leaves a problem of the right size.
  ~UnobservedGuesses() { Restore(); }
  UnobservedGuesses(const UnobservedGuesses&) = delete;
  UnobservedGuesses& operator=(const UnobservedGuesses&) = delete;

  // Every feature back (once): the unobserved ones at their guesses, the
  // others at zero for the placement to overwrite.
  void Restore() {
    if (restored_) return;
    restored_ = true;
    problem_->features.assign(count_, core::Point2::Zero());
    for (const auto& [f, guess] : guesses_) problem_->features[static_cast<size_t>(f)] = guess;
    std::vector<std::pair<int32_t, core::Point2>>().swap(guesses_);
  }

 private:
  core::Problem2d* problem_;
  size_t count_;
  std::vector<std::pair<int32_t, core::Point2>> guesses_;
  bool restored_ = false;
};

}  // namespace

double FeatureSampleKey(int32_t feature) {
  // SplitMix64's finalizer: consecutive indices (features first seen from
  // the same poses) get independent keys.
  uint64_t z = static_cast<uint64_t>(static_cast<uint32_t>(feature)) + 0x9E3779B97F4A7C15ULL;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  z ^= z >> 31;
  return static_cast<double>(z >> 11) * 0x1.0p-53;
}

int64_t SampleBudget(const SampledInitializationOptions& options, int64_t poses) {
  return options.budget_observations > 0
             ? options.budget_observations
             : std::max(options.min_observations, options.observations_per_pose * poses);
}

Status InitializeFromSampledFeatures(const SampledInitializationOptions& options,
                                     const core::SolverOptions& solver,
                                     const core::ChunkSource& chunks, int64_t total_observations,
                                     core::Problem2d* problem,
                                     SampledInitializationSummary* summary) {
  GS_CHECK(problem != nullptr && summary != nullptr);
  *summary = SampledInitializationSummary();
  const auto start = std::chrono::steady_clock::now();
  if (options.observations_per_pose < 1 || options.min_observations < 0 ||
      options.budget_observations < 0 || options.sub_solve_iterations < 0 ||
      !(options.sub_solve_function_tolerance >= 0.0))
    return Status::InvalidArgument(
        "sampled initialization: expected observations_per_pose >= 1, min_observations >= 0, "
        "budget_observations >= 0, sub_solve_iterations >= 0 and "
        "sub_solve_function_tolerance >= 0, got " +
        std::to_string(options.observations_per_pose) + ", " +
        std::to_string(options.min_observations) + ", " +
        std::to_string(options.budget_observations) + ", " +
        std::to_string(options.sub_solve_iterations) + ", " +
        std::to_string(options.sub_solve_function_tolerance));
  int64_t budget = SampleBudget(options, problem->num_poses());
  if (options.max_observations >= 0 && budget > options.max_observations) {
    budget = options.max_observations;
    summary->capped = true;
  }
  summary->budget_observations = budget;
  const double rate =
      total_observations <= budget
          ? 1.0
          : static_cast<double>(budget) / static_cast<double>(total_observations);
  summary->rate = rate;

  // Step 2: the sampled features' observations, in chunk order (features
  // ascending within a chunk, each one's observations in input order).
  core::Problem2d sub = PoseSubProblem(*problem);
  std::optional<PoseConstraintLoan> loan(std::in_place, problem, &sub);
  std::vector<int32_t> sampled;  // sub feature -> feature of *problem
  // The sample, 32 bytes an observation (sub.observations stays empty).
  // Reserved, not grown by doubling: the sample is about B observations.
  CompactObservations sample;
  sample.reserve(static_cast<size_t>(std::min(total_observations, budget + budget / 8)));
  const auto pick = [&](const core::ObservationChunk& chunk,
                        std::vector<core::Observation>* kept) -> Status {
    kept->clear();
    for (size_t slot = 0; slot < chunk.features.size(); ++slot) {
      if (rate < 1.0 && FeatureSampleKey(chunk.features[slot]) >= rate) continue;
      kept->insert(kept->end(), chunk.observations.begin() + chunk.feature_begin[slot],
                   chunk.observations.begin() + chunk.feature_begin[slot + 1]);
    }
    return Status::Ok();
  };
  // Which features the chunks observe, a bit each (see UnobservedGuesses).
  std::vector<bool> observed(problem->features.size(), false);
  Status merged;
  GS_RETURN_IF_ERROR(core::internal::RunOrderedChunkPipeline<std::vector<core::Observation>>(
      chunks, solver.max_chunks_in_flight, pick,
      [&](const core::ObservationChunk& chunk, const std::vector<core::Observation>& kept) {
        for (size_t slot = 0; slot < chunk.features.size(); ++slot) {
          const int32_t f = chunk.features[slot];
          if (chunk.feature_begin[slot] < chunk.feature_begin[slot + 1] && f >= 0 &&
              f < problem->num_features())
            observed[static_cast<size_t>(f)] = true;
        }
        for (core::Observation o : kept) {
          if (o.feature < 0 || o.feature >= problem->num_features() || o.pose < 0 ||
              o.pose >= problem->num_poses()) {
            if (merged.ok())
              merged = Status::Corruption(
                  "chunk " + std::to_string(chunk.index) + ": observation of feature " +
                  std::to_string(o.feature) + " from pose " + std::to_string(o.pose) +
                  ", expected a feature below " + std::to_string(problem->num_features()) +
                  " and a pose below " + std::to_string(problem->num_poses()));
            return;
          }
          if (sampled.empty() || sampled.back() != o.feature) {
            sampled.push_back(o.feature);
            // Parked ids (the caller's, while the start runs): the index names it.
            sub.AddFeature(problem->feature_ids.empty() ? int64_t{o.feature}
                                                        : problem->feature_ids[o.feature],
                           problem->features[o.feature],
                           problem->feature_initialized[o.feature] != 0);
          }
          o.feature = sub.num_features() - 1;
          sample.push_back(o);
        }
      }));
  GS_RETURN_IF_ERROR(merged);
  summary->sampled_features = sub.num_features();
  summary->sampled_observations = static_cast<int64_t>(sample.size());
  UnobservedGuesses unobserved(observed, problem);
  observed = std::vector<bool>();

  // Step 3: incremental initialization of the sample, then its solve.
  // The stages report their progress (the start can take minutes), as in
  // memory; the sample's solve does not pose as the whole problem's.
  GS_RETURN_IF_ERROR(InitializeIncrementally(options.incremental, solver, sample, &sub,
                                             &summary->incremental));
  if (options.sub_solve_iterations > 0 && !sample.empty()) {
    core::SolverOptions sub_options =
        internal::StageSolverOptions(solver, options.sub_solve_iterations);
    sub_options.function_tolerance = options.sub_solve_function_tolerance;
    const SampleChunkSource sub_chunks(sample, options.incremental.max_observations_per_chunk);
    core::SolverSummary solved;
    const Status status = core::SolveGraphSlam(sub_options, sub_chunks, &sub, &solved);
    // Unconverged, or stopped by a numerical failure at its last accepted
    // estimate: still a start for the whole problem's solve.
    if (!status.ok() && !status.IsNumerical()) return status;
    summary->sub_solve_iterations = solved.iterations;
    summary->sub_solve_initial_chi2 = solved.initial_chi2;
    summary->sub_solve_final_chi2 = solved.final_chi2;
    // The solve's long first steps over the whole sample can fold a stretch
    // over as a stage can (10^8: folds after it that no stage had left), so
    // the stages' repair runs once more on its result.
    GS_RETURN_IF_ERROR(RepairBrokenOdometry(options.incremental, solver, sample, &sub,
                                            &summary->incremental));
  }

  // Step 4: the poses back, every feature from first sight, the sampled ones
  // where the sub-problem put them. The sample's observations are done with.
  sample.Release();
  loan.reset();
  problem->poses = std::move(sub.poses);
  unobserved.Restore();
  GS_RETURN_IF_ERROR(PlaceFeaturesFromFirstSight(solver.max_chunks_in_flight, chunks, problem,
                                                 &summary->placed_features));
  for (size_t k = 0; k < sampled.size(); ++k) problem->features[sampled[k]] = sub.features[k];
  summary->seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return Status::Ok();
}

}  // namespace graphslam::partition

#include "partition/initialization/incremental_initialization.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <span>
#include <utility>

#include "core/initialization.h"
#include "core/logging.h"
#include "core/observation_models.h"
#include "core/point_observation_model.h"
#include "core/range_bearing_model.h"
#include "partition/initialization/feature_localization.h"
#include "partition/initialization/gps_segment_alignment.h"
#include "partition/ingest/in_memory_chunk_source.h"
#include "partition/initialization/internal/broken_odometry.h"
#include "partition/initialization/internal/odometry_chain.h"
#include "partition/initialization/internal/stage_growth.h"
#include "partition/initialization/internal/stage_setup.h"
#include "partition/initialization/internal/window_stage.h"
#include "partition/initialization/singleton_solve.h"

namespace graphslam::partition {
namespace {

using core::Point2;
using core::Pose2;
using internal::EdgeKind;
using internal::Indices;
using internal::PoseLink;
using internal::StageBuilder;


// A stage that did not converge and whose chi2 fell by more than this
// factor is redone (header); slow convergence near the start (a robust
// kernel's reweighting: MRCLAM's stages end 1.1-2.3 times below their start)
// is not.
constexpr double kFarStartChi2Ratio = 10.0;


// Puts the new poses [begin, end) onto their GPS fixes, odometry stretch by
// odometry stretch (partition/initialization/gps_segment_alignment.h), before the stage
// solves them: a stretch chained over hundreds of poses can be far from its
// fixes, and a window started there can settle in a local minimum that later
// windows, which hold it fixed, never leave (a 30 000-pose campus with GPS
// every 50 poses ended at chi2/dof 12 without this). O(end - begin).
void AlignNewPosesToGps(const core::Problem2d& problem, const Indices& index, int32_t begin,
                        int32_t end, std::vector<Pose2>* poses) {
  if (problem.gps.empty() || end - begin < 2) return;
  core::Problem2d stretch;
  for (int32_t p = begin; p < end; ++p) {
    stretch.AddPose(problem.pose_ids[p], (*poses)[p], true, problem.pose_lines[p]);
    stretch.pose_fixed.back() = problem.pose_fixed[p];
  }
  for (int32_t p = begin; p < end; ++p) {
    for (const PoseLink& l : index.links[p]) {
      if (l.other <= p || l.other >= end) continue;  // each edge once, inside the stretch
      if (l.kind == EdgeKind::kRelativePose) {
        core::RelativePoseConstraint c = problem.relative_poses[l.constraint];
        c.from -= begin;
        c.to -= begin;
        stretch.relative_poses.push_back(c);
      } else if (l.kind == EdgeKind::kMotion) {
        core::VelocityMotionConstraint c = problem.motions[l.constraint];
        c.from -= begin;
        c.to -= begin;
        stretch.motions.push_back(c);
      }
    }
    for (int64_t i = index.gps_of_pose.begin(p); i < index.gps_of_pose.end(p); ++i) {
      core::GpsConstraint c = problem.gps[index.gps_of_pose.items[i]];
      c.pose -= begin;
      stretch.gps.push_back(c);
    }
  }
  if (stretch.gps.size() < 2) return;
  AlignOdometryToGps(&stretch);
  for (int32_t p = begin; p < end; ++p) (*poses)[p] = stretch.poses[p - begin];
}

// Rounds of the repair after the last stage (header: repair): a stretch
// whose re-solved window still leaves a step broken is tried again from the
// improved estimate, at most this many times in all.
constexpr int kRepairRounds = 3;

// Values of the per-feature placed flags: placed from a new pose of the
// current stage, or solved by a stage kept.
constexpr uint8_t kFeaturePlaced = 1;
constexpr uint8_t kFeatureSolved = 2;

// The features first seen from poses [begin, end), placed from their first
// sighting (lowest pose, then input order); their indices in *new_features.
// Before its features are placed, each pose not fixed is localized from the
// placed features it sees (partition/initialization/feature_localization.h;
// it keeps its chained guess when it sees too few), those solved by earlier
// stages first.
template <class Observations>
void PlaceNewFeatures(const core::Problem2d& problem, const Observations& observations,
                      const Indices& index, int32_t begin, int32_t end, std::vector<Pose2>* poses,
                      std::vector<uint8_t>* feature_placed, std::vector<Point2>* features,
                      std::vector<int32_t>* new_features) {
  new_features->clear();
  std::vector<core::Observation> own;  // of pose p
  Pose2 chained_before = Pose2::Zero();  // pose p - 1 as chained, before localization
  for (int32_t p = begin; p < end; ++p) {
    const Pose2 chained = (*poses)[p];
    own.clear();
    for (int64_t i = index.observations_of_pose.begin(p); i < index.observations_of_pose.end(p);
         ++i)
      own.push_back(observations[index.observations_of_pose.items[i]]);
    if (problem.pose_fixed[p] == 0) {
      // The chained step from p - 1 taken from where p - 1 ended up: a pose
      // that sees too few placed features follows its localized predecessor.
      const Pose2 guess =
          p > begin && problem.pose_fixed[p - 1] == 0
              ? core::Compose((*poses)[p - 1], core::Between(chained_before, chained))
              : chained;
      // Features an earlier stage solved first: the ones placed from this
      // stage's new poses carry their chained error (a pose re-entering a
      // street seen before, after a stretch chained by weak odometry).
      FeatureLocalizationOptions solved;
      solved.placed_at_least = kFeatureSolved;
      if (!LocalizeFromFeatures(solved, own, *features, *feature_placed, guess, &(*poses)[p])
               .localized)
        LocalizeFromFeatures(FeatureLocalizationOptions(), own, *features, *feature_placed, guess,
                             &(*poses)[p]);
    }
    chained_before = chained;
    for (const core::Observation& o : own) {
      if ((*feature_placed)[o.feature]) continue;
      (*feature_placed)[o.feature] = kFeaturePlaced;
      new_features->push_back(o.feature);
      (*features)[o.feature] = core::InvertObservation(o.kind, (*poses)[o.pose], o.z);
    }
  }
}

// A stage that did not converge within its iterations and lowered chi2 more
// than kFarStartChi2Ratio-fold on the way (header: redo): its new poses started
// far outside the basin, so it is discarded and done again with half of them,
// unless it already has no more than `floor_new_poses`. Also when its last
// iteration had stopped descending (settled, internal/stage_growth.h): such a
// stage has settled in a wrong basin, and keeping it leaves the whole sample
// off its optimum (docs/design.md, "Redone stages").
bool IsFarStart(const IncrementalInitializationOptions& options,
                const core::SolverSummary& solver, int64_t new_poses, int64_t floor_new_poses) {
  return options.max_iterations_per_stage > 0 && !solver.converged &&
         solver.initial_chi2 > kFarStartChi2Ratio * solver.final_chi2 &&
         new_poses > floor_new_poses;
}

// A full stage's solver options: a window stage's, with
// full_stage_function_tolerance in place of the caller's when set.
core::SolverOptions FullStageOptions(const IncrementalInitializationOptions& options,
                                     const core::SolverOptions& stage) {
  core::SolverOptions full = stage;
  if (options.full_stage_function_tolerance > 0.0)
    full.function_tolerance = options.full_stage_function_tolerance;
  return full;
}

// One stage's sub-problem, its unknown poses and what its solve did.
struct StageSolve {
  std::vector<int32_t> unknown;
  core::Problem2d sub;
  core::SolverSummary solver;
  IncrementalStageSummary summary;
};

// The stages of InitializeIncrementally over a working copy of the estimate:
// *problem changes only in Finish, when every stage succeeded.
template <class Observations>
class IncrementalStages {
 public:
  IncrementalStages(const IncrementalInitializationOptions& options,
                    const core::SolverOptions& base, const core::Problem2d& problem,
                    const Observations& observations)
      : options_(options),
        problem_(problem),
        observations_(observations),
        index_(internal::BuildIndices(problem, observations)),
        adjacency_(internal::OdometryAdjacency(problem)),
        builder_(problem, observations, index_),
        stage_options_(internal::StageSolverOptions(base, options.max_iterations_per_stage)),
        full_stage_options_(FullStageOptions(options, stage_options_)),
        poses_(problem.poses),
        features_(problem.features),
        placed_(problem.poses.size(), 0),
        feature_placed_(problem.features.size(), 0),
        mark_(problem.poses.size(), 0),
        mark_feature_(problem.features.size(), 0) {
    // Anchors stay put.
    for (size_t p = 0; p < placed_.size(); ++p) placed_[p] = problem.pose_fixed[p] != 0;
    chunking_.max_observations_per_chunk = options.max_observations_per_chunk;
  }

  // Start values of the new poses [previous, t) (the input guess for the
  // first stage, chained along the odometry after it, then put onto their
  // GPS fixes) and of the features they see first.
  void Place(int32_t previous, int32_t t) {
    if (previous == 0) {
      for (int32_t p = 0; p < t; ++p) placed_[p] = 1;  // the input guess
    } else {
      internal::PlacePoses(problem_, adjacency_, previous, t, &poses_, &placed_);
    }
    AlignNewPosesToGps(problem_, index_, previous, t, &poses_);
    PlaceNewFeatures(problem_, observations_, index_, previous, t, &poses_, &feature_placed_,
                     &features_, &new_features_);
  }

  // Builds and solves the stage W_k of the poses [0, t) whose new ones start
  // at `new_begin`: all of them when `full`, else the window and the old ends
  // of the new loop closures. `stage` numbers it in error messages.
  Status Solve(int32_t attempt, int32_t new_begin, int32_t t, bool full, size_t stage,
               StageSolve* out) {
    const int32_t window_begin = full ? 0 : WindowBegin(new_begin, t);
    out->unknown = internal::UnknownPoses(options_.loop_closure_poses,
                                         options_.max_loop_closure_poses, index_, new_begin,
                                         window_begin, t, &mark_);
    IncrementalStageSummary& summary = out->summary;
    out->sub = builder_.Build(attempt, out->unknown, window_begin, t,
                              options_.max_prior_observations_per_feature, poses_, features_,
                              &summary.constraints);
    summary.poses = t;
    summary.full = full;
    summary.solved_poses = static_cast<int64_t>(out->unknown.size());
    summary.fixed_poses = builder_.fixed_poses();
    summary.features = out->sub.num_features();
    summary.observations = static_cast<int64_t>(out->sub.observations.size());
    // The stage's observations are needed no more once cut into chunks.
    Status status = SolveWithoutSingletons(full ? full_stage_options_ : stage_options_,
                                           chunking_, &out->sub, &out->solver, nullptr,
                                           /*release_observations=*/true);
    if (!status.ok())
      return status.WithContext("incremental initialization stage " + std::to_string(stage) +
                                " (" + std::to_string(t) + " poses)");
    summary.initial_chi2 = out->solver.initial_chi2;
    summary.final_chi2 = out->solver.final_chi2;
    summary.iterations = out->solver.iterations;
    summary.termination = out->solver.termination;
    return Status::Ok();
  }

  // The last pose of the stage after `previous` at most at t whose new poses
  // [previous, result) hold at most max_new_observations observations (at
  // least one new pose).
  int32_t CapNewPoses(int32_t previous, int32_t t) const {
    const std::vector<int64_t>& before = index_.observations_of_pose.offsets;
    const int64_t limit = before[previous] + options_.max_new_observations;
    const auto end = std::upper_bound(before.begin() + previous + 1, before.begin() + t + 1, limit);
    return std::max(previous + 1, static_cast<int32_t>(end - before.begin()) - 1);
  }

  // The first pose of a window stage's window ending at t (header: the most
  // recent window_poses poses holding at most max_window_observations
  // observations, and at most window_observations_per_new times the new
  // poses' when set), never above new_begin.
  int32_t WindowBegin(int32_t new_begin, int32_t t) const {
    const std::vector<int64_t>& before = index_.observations_of_pose.offsets;
    const int32_t by_poses = static_cast<int32_t>(std::max<int64_t>(0, t - options_.window_poses));
    const double new_observations = static_cast<double>(before[t] - before[new_begin]);
    int64_t budget = options_.max_window_observations;
    if (options_.window_observations_per_new > 0.0)
      budget = std::min<int64_t>(budget, static_cast<int64_t>(std::ceil(
                                             options_.window_observations_per_new *
                                             new_observations)));
    const auto first =
        std::lower_bound(before.begin() + by_poses, before.begin() + t, before[t] - budget);
    return std::min(new_begin, static_cast<int32_t>(first - before.begin()));
  }

  // Discards a stage: its new poses [new_begin, t) and features unplaced.
  void Undo(int32_t new_begin, int32_t t) {
    for (int32_t p = new_begin; p < t; ++p) {
      poses_[p] = problem_.poses[p];
      placed_[p] = problem_.pose_fixed[p] != 0;
    }
    for (int32_t f : new_features_) feature_placed_[f] = 0;
  }

  // The worst chi2 of one odometry or motion step touching the new poses
  // [new_begin, t) at the stage's solution (internal/broken_odometry.h).
  double WorstNewOdometryChi2(const StageSolve& stage, int32_t new_begin, int32_t t) {
    touched_.assign(stage.sub.poses.size(), 0);
    for (int32_t p = new_begin; p < t; ++p) {
      const int32_t local = builder_.local_pose(p);
      if (local >= 0) touched_[local] = 1;
    }
    return internal::WorstOdometryChi2(stage.sub, touched_);
  }

  // Keeps a stage: its solved poses and features become the estimate.
  void Keep(const StageSolve& stage) {
    for (int32_t p : stage.unknown) poses_[p] = stage.sub.poses[builder_.local_pose(p)];
    const std::vector<int32_t>& sub_features = builder_.sub_features();
    for (size_t j = 0; j < sub_features.size(); ++j)
      features_[sub_features[j]] = stage.sub.features[j];
    for (int32_t f : new_features_) feature_placed_[f] = kFeatureSolved;
  }

  // The repair after the last stage (header: repair): each stretch of
  // broken odometry steps, re-chained from its first pose and re-solved in a
  // window of `margin` poses on either side, kept when that beats the fold.
  // `*id` numbers the sub-problems after the stages'.
  Status Repair(int64_t margin, int32_t* id, IncrementalSummary* summary) {
    for (int round = 0; round < kRepairRounds; ++round) {
      GS_ASSIGN_OR_RETURN(const int64_t kept, RepairRound(round, margin, id, summary));
      if (kept == 0) break;
    }
    return Status::Ok();
  }

  // One round of Repair over the steps broken now; how many stretches it
  // replaced.
  StatusOr<int64_t> RepairRound(int round, int64_t margin, int32_t* id,
                                IncrementalSummary* summary) {
    const std::vector<internal::BrokenStep> broken =
        internal::BrokenOdometrySteps(problem_, poses_, options_.RepairChi2());
    const int32_t n = problem_.num_poses();
    int64_t replaced = 0;
    for (size_t i = 0; i < broken.size();) {
      // A stretch: steps no more than `margin` poses apart. It joins poses
      // [lo, hi], the first and last broken steps at lo and hi - 1.
      const int32_t lo = broken[i].pose;
      int32_t hi = lo + 1;
      for (; i < broken.size() && broken[i].pose <= hi + margin; ++i)
        hi = std::max(hi, broken[i].pose + 1);
      const int32_t begin = static_cast<int32_t>(std::max<int64_t>(0, lo - margin));
      const int32_t end = static_cast<int32_t>(std::min<int64_t>(n, hi + margin + 1));
      if (round == 0) ++summary->broken_odometry_stretches;
      GS_ASSIGN_OR_RETURN(const bool kept, RepairStretch(lo, hi, begin, end, id));
      if (kept) {
        ++summary->broken_odometry_repairs;
        ++replaced;
      }
    }
    return replaced;
  }

  // Every pose counts as placed: the repair alone on a finished estimate.
  void MarkAllPlaced() { std::fill(placed_.begin(), placed_.end(), 1); }

  void Finish(core::Problem2d* problem) {
    problem->poses = std::move(poses_);
    problem->features = std::move(features_);
    for (size_t f = 0; f < feature_placed_.size(); ++f)
      if (feature_placed_[f]) problem->feature_initialized[f] = 1;
  }

 private:
  // One stretch of Repair: the window [begin, end) as it is (evaluated, not
  // solved) against the window solved after the poses (lo, hi] are chained
  // along the odometry from lo and every feature they see is placed from
  // its first sighting among them. Keeps the second when its chi2 is lower
  // (a step it still leaves broken is taken up by the next round); else
  // puts everything back. True when kept.
  StatusOr<bool> RepairStretch(int32_t lo, int32_t hi, int32_t begin, int32_t end, int32_t* id) {
    std::vector<int32_t> window;
    for (int32_t p = begin; p < end; ++p) window.push_back(p);
    const int32_t n = problem_.num_poses();
    core::SolverOptions evaluate = stage_options_;
    evaluate.max_iterations = 0;
    StageSolve before;
    before.unknown = window;
    before.sub = builder_.Build((*id)++, window, begin, n,
                                options_.max_prior_observations_per_feature, poses_, features_,
                                &before.summary.constraints);
    GS_RETURN_IF_ERROR(SolveWithoutSingletons(evaluate, chunking_, &before.sub, &before.solver,
                                              nullptr, /*release_observations=*/true));

    const std::vector<Pose2> saved_poses(poses_.begin() + lo + 1, poses_.begin() + hi + 1);
    std::vector<std::pair<int32_t, Point2>> saved_features;
    for (int32_t p = lo + 1; p <= hi; ++p) placed_[p] = problem_.pose_fixed[p] != 0;
    internal::PlacePoses(problem_, adjacency_, lo + 1, hi + 1, &poses_, &placed_);
    for (int32_t p = lo + 1; p <= hi; ++p) {
      for (int64_t i = index_.observations_of_pose.begin(p);
           i < index_.observations_of_pose.end(p); ++i) {
        const core::Observation o = observations_[index_.observations_of_pose.items[i]];
        if (mark_feature_[o.feature]) continue;
        mark_feature_[o.feature] = 1;
        saved_features.emplace_back(o.feature, features_[o.feature]);
        features_[o.feature] = core::InvertObservation(o.kind, poses_[p], o.z);
      }
    }
    for (const auto& [f, _] : saved_features) mark_feature_[f] = 0;

    StageSolve after;
    after.unknown = window;
    after.sub = builder_.Build((*id)++, window, begin, n,
                               options_.max_prior_observations_per_feature, poses_, features_,
                               &after.summary.constraints);
    GS_RETURN_IF_ERROR(SolveWithoutSingletons(stage_options_, chunking_, &after.sub,
                                              &after.solver, nullptr,
                                              /*release_observations=*/true));
    touched_.assign(after.sub.poses.size(), 0);
    for (int32_t p : window) touched_[builder_.local_pose(p)] = 1;
    const double worst = internal::WorstOdometryChi2(after.sub, touched_);
    const bool keep = after.solver.final_chi2 < before.solver.initial_chi2;
    GS_VLOG(1, "incremental initialization: broken odometry at poses %d-%d, window %d-%d: "
               "chi2 %.6g as it was, %.6g re-chained (worst step %.6g): %s",
            lo, hi, begin, end - 1, before.solver.initial_chi2, after.solver.final_chi2, worst,
            keep ? "repaired" : "left");
    if (keep) {
      for (int32_t p : window) poses_[p] = after.sub.poses[builder_.local_pose(p)];
      const std::vector<int32_t>& sub_features = builder_.sub_features();
      for (size_t j = 0; j < sub_features.size(); ++j)
        features_[sub_features[j]] = after.sub.features[j];
      return true;
    }
    std::copy(saved_poses.begin(), saved_poses.end(), poses_.begin() + lo + 1);
    for (const auto& [f, position] : saved_features) features_[f] = position;
    return false;
  }

  const IncrementalInitializationOptions& options_;
  const core::Problem2d& problem_;
  const Observations& observations_;
  const Indices index_;
  const std::vector<std::vector<internal::PoseEdge>> adjacency_;
  StageBuilder<Observations> builder_;
  const core::SolverOptions stage_options_;
  const core::SolverOptions full_stage_options_;  // header: full_stage_function_tolerance
  ChunkingOptions chunking_;
  std::vector<Pose2> poses_;
  std::vector<Point2> features_;
  std::vector<uint8_t> placed_;
  std::vector<uint8_t> feature_placed_;
  std::vector<int32_t> new_features_;  // placed by the last Place
  std::vector<uint8_t> mark_;          // UnknownPoses' scratch
  std::vector<uint8_t> touched_;       // WorstNewOdometryChi2's scratch
  std::vector<uint8_t> mark_feature_;  // RepairStretch's scratch
};

void LogStage(size_t stage, const IncrementalStageSummary& s) {
  GS_VLOG(1, "incremental initialization: stage %zu, %d poses (%lld solved, %lld fixed), "
             "%lld features, chi2 %.6g -> %.6g in %d iterations (%s), %.3f s",
          stage, static_cast<int>(s.poses), static_cast<long long>(s.solved_poses),
          static_cast<long long>(s.fixed_poses), static_cast<long long>(s.features),
          s.initial_chi2, s.final_chi2, s.iterations, s.termination.c_str(), s.seconds);
}

}  // namespace

Status IncrementalInitializationOptions::Validate() const {
  auto fail = [](const std::string& what, const std::string& got) {
    return Status::InvalidArgument("incremental initialization: " + what + ", got " + got);
  };
  if (first_poses < 1) return fail("first_poses must be >= 1", std::to_string(first_poses));
  if (!(growth > 1.0) || !std::isfinite(growth))
    return fail("growth must be finite and > 1", std::to_string(growth));
  if (max_new_poses < 1) return fail("max_new_poses must be >= 1", std::to_string(max_new_poses));
  if (min_new_poses < 1) return fail("min_new_poses must be >= 1", std::to_string(min_new_poses));
  if (window_poses < max_new_poses)
    return fail("window_poses must be >= max_new_poses (" + std::to_string(max_new_poses) + ")",
                std::to_string(window_poses));
  if (!(window_observations_per_new >= 0.0) || !std::isfinite(window_observations_per_new))
    return fail("window_observations_per_new must be finite and >= 0 (0: off)",
                std::to_string(window_observations_per_new));
  if (!(full_stage_function_tolerance >= 0.0) || !std::isfinite(full_stage_function_tolerance))
    return fail("full_stage_function_tolerance must be finite and >= 0 (0: the solver's)",
                std::to_string(full_stage_function_tolerance));
  if (max_new_observations < 1)
    return fail("max_new_observations must be >= 1", std::to_string(max_new_observations));
  if (max_window_observations < max_new_observations)
    return fail("max_window_observations must be >= max_new_observations (" +
                    std::to_string(max_new_observations) + ")",
                std::to_string(max_window_observations));
  if (loop_closure_poses < 0)
    return fail("loop_closure_poses must be >= 0", std::to_string(loop_closure_poses));
  if (max_loop_closure_poses < 0)
    return fail("max_loop_closure_poses must be >= 0", std::to_string(max_loop_closure_poses));
  if (max_prior_observations_per_feature < 0)
    return fail("max_prior_observations_per_feature must be >= 0",
                std::to_string(max_prior_observations_per_feature));
  if (full_stage_growth != 0.0 && (!(full_stage_growth > 1.0) || !std::isfinite(full_stage_growth)))
    return fail("full_stage_growth must be 0 (off) or finite and > 1",
                std::to_string(full_stage_growth));
  if (!(broken_odometry_chi2 >= 0.0) || !std::isfinite(broken_odometry_chi2))
    return fail("broken_odometry_chi2 must be finite and >= 0 (0: off)",
                std::to_string(broken_odometry_chi2));
  if (!(broken_odometry_repair_chi2 >= 0.0) || !std::isfinite(broken_odometry_repair_chi2))
    return fail("broken_odometry_repair_chi2 must be finite and >= 0 (0: broken_odometry_chi2)",
                std::to_string(broken_odometry_repair_chi2));
  if (broken_odometry_repair_poses < 0)
    return fail("broken_odometry_repair_poses must be >= 0 (0: off)",
                std::to_string(broken_odometry_repair_poses));
  if (max_iterations_per_stage < 0)
    return fail("max_iterations_per_stage must be >= 0", std::to_string(max_iterations_per_stage));
  if (max_observations_per_chunk < 1)
    return fail("max_observations_per_chunk must be >= 1",
                std::to_string(max_observations_per_chunk));
  return Status::Ok();
}

namespace {

// InitializeIncrementally (header) with the problem's observations in
// `observations`, checked by the caller.
template <class Observations>
Status RunStages(const IncrementalInitializationOptions& options, const core::SolverOptions& base,
                 const Observations& observations, core::Problem2d* problem,
                 IncrementalSummary* summary) {
  const StageClock::time_point start = StageClock::now();
  const int32_t n = problem->num_poses();

  IncrementalStages<Observations> stages(options, base, *problem, observations);
  int64_t allowed = options.max_new_poses;
  // The next prefix length solved whole (header: full stages).
  double next_full = options.full_stage_growth > 0.0
                         ? options.full_stage_growth * static_cast<double>(options.first_poses)
                         : static_cast<double>(n) + 1.0;
  const int64_t floor_new_poses = std::min(options.min_new_poses, options.max_new_poses);
  int32_t previous = 0;
  int32_t t = static_cast<int32_t>(std::min<int64_t>(options.first_poses, n));
  bool t_chosen = true;  // t set by the first stage or by a redo
  bool redone = false;   // the stage kept last was a redo
  int32_t id = 0;  // numbers the sub-problems
  for (;; ++id) {
    const int32_t attempt = id;
    if (!t_chosen) t = internal::NextStageSize(options.growth, allowed, previous, n);
    t = stages.CapNewPoses(previous, t);
    t_chosen = false;
    const StageClock::time_point stage_start = StageClock::now();
    stages.Place(previous, t);
    const int32_t new_begin = previous;
    // A full stage with fewer than a quarter of its prefix still to come is
    // left to the caller's full solve, which does the same job a few poses
    // later (header: full stages).
    const bool full = static_cast<double>(t) >= next_full && 4 * (int64_t{n} - t) > t;
    StageSolve stage;
    GS_RETURN_IF_ERROR(
        stages.Solve(attempt, new_begin, t, full, summary->stages.size(), &stage));
    stage.summary.seconds = StageSecondsSince(stage_start);
    const bool far = IsFarStart(options, stage.solver, t - new_begin, floor_new_poses);
    const double worst_odometry =
        !far && options.broken_odometry_chi2 > 0.0 && options.max_iterations_per_stage > 0 &&
                t - new_begin > floor_new_poses
            ? stages.WorstNewOdometryChi2(stage, new_begin, t)
            : 0.0;
    const bool broken = worst_odometry > options.broken_odometry_chi2;
    if (far || broken) {
      allowed = std::max<int64_t>(floor_new_poses, (t - new_begin) / 2);
      if (far) {
        GS_VLOG(1, "incremental initialization: %d poses not converged in %d iterations "
                   "(chi2 %.6g -> %.6g): redone with %lld new poses",
                t, stage.summary.iterations, stage.summary.initial_chi2,
                stage.summary.final_chi2, static_cast<long long>(allowed));
      } else {
        GS_VLOG(1, "incremental initialization: %d poses leave an odometry step at chi2 %.6g "
                   "(above %.6g): redone with %lld new poses",
                t, worst_odometry, options.broken_odometry_chi2, static_cast<long long>(allowed));
        ++summary->broken_odometry_redos;
      }
      stages.Undo(new_begin, t);
      t = static_cast<int32_t>(new_begin + allowed);
      t_chosen = true;
      redone = true;
      ++summary->redone_stages;
      continue;
    }
    previous = t;
    while (static_cast<double>(t) >= next_full) next_full *= options.full_stage_growth;
    stages.Keep(stage);
    LogStage(summary->stages.size(), stage.summary);
    summary->stages.push_back(std::move(stage.summary));
    if (base.progress) base.progress("incremental initialization", t, n);
    if (t == n) break;
    if (options.max_iterations_per_stage > 0 && !redone) {
      // Unsettled (at the floor, so not redone): fewer new poses next time.
      // After a redo the next stage adds as many as the redo did: twice that
      // many just failed.
      allowed = internal::NextAllowedNewPoses(stage.solver, allowed, options.min_new_poses,
                                              options.max_new_poses);
    }
    redone = false;
  }
  if (options.broken_odometry_chi2 > 0.0 && options.max_iterations_per_stage > 0 &&
      options.broken_odometry_repair_poses > 0) {
    ++id;  // past the last stage's
    GS_RETURN_IF_ERROR(stages.Repair(options.broken_odometry_repair_poses, &id, summary));
  }
  stages.Finish(problem);
  summary->seconds = StageSecondsSince(start);
  return Status::Ok();
}

}  // namespace

Status InitializeIncrementally(const IncrementalInitializationOptions& options,
                               const core::SolverOptions& base, core::Problem2d* problem,
                               IncrementalSummary* summary) {
  GS_ASSIGN_OR_RETURN(const bool has_stages,
                      BeginPrefixStages(options, base, *problem, summary,
                                        [](const core::Problem2d& p) -> Status {
                                          GS_RETURN_IF_ERROR(internal::CheckPerElementArrays(p));
                                          return core::ValidateProblem(p);  // indices in range
                                        }));
  if (!has_stages) return Status::Ok();
  return RunStages(options, base, problem->observations, problem, summary);
}

namespace {

// RepairBrokenOdometry (header) with the problem's observations in
// `observations`.
template <class Observations>
Status RunRepair(const IncrementalInitializationOptions& options, const core::SolverOptions& base,
                 const Observations& observations, core::Problem2d* problem,
                 IncrementalSummary* summary) {
  GS_RETURN_IF_ERROR(options.Validate());
  GS_RETURN_IF_ERROR(internal::CheckPerElementArrays(*problem));
  GS_RETURN_IF_ERROR(core::ValidateProblem(*problem));
  if (options.broken_odometry_chi2 <= 0.0 || options.max_iterations_per_stage <= 0 ||
      options.broken_odometry_repair_poses <= 0)
    return Status::Ok();
  IncrementalStages<Observations> stages(options, base, *problem, observations);
  stages.MarkAllPlaced();
  int32_t id = 0;
  GS_RETURN_IF_ERROR(stages.Repair(options.broken_odometry_repair_poses, &id, summary));
  stages.Finish(problem);
  return Status::Ok();
}

}  // namespace

Status RepairBrokenOdometry(const IncrementalInitializationOptions& options,
                            const core::SolverOptions& base, core::Problem2d* problem,
                            IncrementalSummary* summary) {
  return RunRepair(options, base, problem->observations, problem, summary);
}

Status RepairBrokenOdometry(const IncrementalInitializationOptions& options,
                            const core::SolverOptions& base,
                            const CompactObservations& observations, core::Problem2d* problem,
                            IncrementalSummary* summary) {
  return RunRepair(options, base, observations, problem, summary);
}

Status InitializeIncrementally(const IncrementalInitializationOptions& options,
                               const core::SolverOptions& base,
                               const CompactObservations& observations, core::Problem2d* problem,
                               IncrementalSummary* summary) {
  GS_ASSIGN_OR_RETURN(
      const bool has_stages,
      BeginPrefixStages(options, base, *problem, summary,
                        [&](const core::Problem2d& p) -> Status {
                          GS_RETURN_IF_ERROR(internal::CheckPerElementArrays(p));
                          if (!p.observations.empty())
                            return Status::InvalidArgument(
                                "incremental initialization: expected the observations in the "
                                "compact list only, got " +
                                std::to_string(p.observations.size()) + " in the problem too");
                          GS_RETURN_IF_ERROR(core::ValidateProblem(p));
                          for (size_t k = 0; k < observations.size(); ++k)
                            if (observations.pose(k) < 0 || observations.pose(k) >= p.num_poses() ||
                                observations.feature(k) < 0 ||
                                observations.feature(k) >= p.num_features())
                              return Status::InvalidArgument(
                                  "incremental initialization: compact observation " +
                                  std::to_string(k) + " of feature " +
                                  std::to_string(observations.feature(k)) + " from pose " +
                                  std::to_string(observations.pose(k)) +
                                  ", expected a feature below " +
                                  std::to_string(p.num_features()) + " and a pose below " +
                                  std::to_string(p.num_poses()));
                          return Status::Ok();
                        }));
  if (!has_stages) return Status::Ok();
  return RunStages(options, base, observations, problem, summary);
}

}  // namespace graphslam::partition

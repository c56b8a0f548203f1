#include "core/chunk_passes.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <atomic>
#include <string>

#include "core/feature_linearizer.h"
#include "core/internal/chunk_pass_kernels.h"
#include "core/internal/ordered_chunk_pipeline.h"
#include "core/internal/pose_pair_set.h"
#include "core/schur_eliminator.h"

namespace graphslam::core {
namespace {

template <class Space>
bool Excluded(const BasicPassContext<Space>& context, int32_t feature) {
  return context.excluded != nullptr && (*context.excluded)[feature] != 0;
}

template <class Space>
void Report(const BasicPassContext<Space>& context, const char* stage, int64_t done) {
  if (context.progress) context.progress(stage, done, context.chunks->NumChunks());
}

template <class Space>
using ChunkOf = BasicObservationChunk<typename Space::Observation>;

// The free poses observing feature slot k, ascending, each once.
template <class Space>
void ObservingPoses(const ChunkOf<Space>& chunk, int64_t k, const UnknownLayout& layout,
                    std::vector<int>* poses) {
  poses->clear();
  for (int64_t o = chunk.feature_begin[k]; o < chunk.feature_begin[k + 1]; ++o) {
    const int32_t u = layout.unknown_index[chunk.observations[o].pose];
    if (u >= 0) poses->push_back(u);
  }
  std::sort(poses->begin(), poses->end());
  poses->erase(std::unique(poses->begin(), poses->end()), poses->end());
}

// All pairs (a <= b) of `poses` not yet in *seen, appended to *pairs.
void InsertAllPairs(const std::vector<int>& poses, internal::PosePairSet* seen,
                    std::vector<std::pair<int, int>>* pairs) {
  for (size_t a = 0; a < poses.size(); ++a)
    for (size_t b = a; b < poses.size(); ++b) seen->Insert(poses[a], poses[b], pairs);
}

}  // namespace

template <class Space>
Status ScreenFeatures(const BasicPassContext<Space>& context,
                      const std::vector<typename Space::Pose>& poses,
                      const std::vector<typename Space::Point>& features,
                      int64_t max_eliminated_observations, ScreeningResult* result,
                      ScreenedPattern* pattern) {
  using FeatureMatrix = Eigen::Matrix<double, Space::kFeatureDim, Space::kFeatureDim>;
  struct Output {
    BasicLinearizedFeature<Space> scratch;
    std::vector<int32_t> rejected;
    std::vector<int32_t> kept;
    int64_t observations = 0;
    // The pattern (when asked): as CollectReducedPattern's Output.
    internal::PosePairSet seen;
    std::vector<int> poses;
    std::vector<std::pair<int, int>> pairs;
    std::vector<std::pair<int32_t, int>> kept_observers;
  };
  if (pattern != nullptr) *pattern = ScreenedPattern();
  result->excluded.assign(features.size(), 1);  // unobserved until a chunk says otherwise
  result->kept.assign(features.size(), 0);
  result->kept_count = 0;
  result->excluded_not_positive_definite = 0;
  result->observations = 0;
  std::vector<uint8_t> observed(features.size(), 0);
  Status status = internal::RunOrderedChunkPipeline<Output>(
      *context.chunks, context.max_in_flight,
      [&](const ChunkOf<Space>& chunk, Output* out) {
        out->rejected.clear();
        out->kept.clear();
        out->observations = 0;
        out->seen.Clear();
        out->pairs.clear();
        out->kept_observers.clear();
        for (int64_t k = 0; k < chunk.num_features(); ++k) {
          const int32_t g = chunk.features[k];
          LinearizeFeature<Space>(chunk, k, poses, features[g], *context.layout, RobustKernel(),
                                  &out->scratch, LinearizeWhat::kInformation);
          const FeatureMatrix c = out->scratch.blocks.feature_information;
          Eigen::SelfAdjointEigenSolver<FeatureMatrix> eigen;
          if constexpr (Space::kFeatureDim == 2) {
            eigen.computeDirect(c, Eigen::EigenvaluesOnly);  // closed form, as EliminateFeature
          } else {
            eigen.compute(c, Eigen::EigenvaluesOnly);
          }
          const double max_eigen = eigen.eigenvalues().maxCoeff();
          const double min_eigen = eigen.eigenvalues().minCoeff();
          // Relative test: a rank-deficient C has min/max at round-off level.
          if (!c.allFinite() || !(max_eigen > 0.0) || min_eigen <= 1e-10 * max_eigen) {
            out->rejected.push_back(g);
          } else {
            const int64_t count = chunk.feature_begin[k + 1] - chunk.feature_begin[k];
            out->observations += count;
            const bool kept = count > max_eliminated_observations;
            if (kept) out->kept.push_back(g);
            if (pattern != nullptr) {
              ObservingPoses<Space>(chunk, k, *context.layout, &out->poses);
              if (kept) {
                for (int u : out->poses) out->kept_observers.emplace_back(g, u);
              } else {
                InsertAllPairs(out->poses, &out->seen, &out->pairs);
              }
            }
          }
        }
        return Status::Ok();
      },
      [&](const ChunkOf<Space>& chunk, Output& out) {
        for (int32_t g : chunk.features) {
          observed[g] = 1;
          result->excluded[g] = 0;
        }
        for (int32_t g : out.rejected) result->excluded[g] = 1;
        for (int32_t g : out.kept) result->kept[g] = 1;
        result->kept_count += static_cast<int64_t>(out.kept.size());
        result->excluded_not_positive_definite += static_cast<int64_t>(out.rejected.size());
        result->observations += out.observations;
        if (pattern != nullptr) {
          pattern->pose_pairs.insert(pattern->pose_pairs.end(), out.pairs.begin(),
                                     out.pairs.end());
          pattern->kept_observers.insert(pattern->kept_observers.end(),
                                         out.kept_observers.begin(), out.kept_observers.end());
        }
        Report(context, "screen", chunk.index + 1);
      });
  result->unobserved = std::count(observed.begin(), observed.end(), 0);
  return status;
}

void AppendScreenedPattern(const UnknownLayout& layout, ScreenedPattern* pattern,
                           std::vector<std::pair<int, int>>* pairs) {
  pairs->insert(pairs->end(), pattern->pose_pairs.begin(), pattern->pose_pairs.end());
  int32_t last = -1;
  for (const auto& [g, u] : pattern->kept_observers) {
    const int fu = layout.feature_unknown_index[g];
    if (g != last) pairs->emplace_back(fu, fu);
    last = g;
    pairs->emplace_back(u, fu);
  }
  *pattern = ScreenedPattern();
}

template <class Space>
Status CollectReducedPattern(const BasicPassContext<Space>& context,
                             std::vector<std::pair<int, int>>* pairs) {
  struct Output {
    internal::PosePairSet seen;  // each pair once per chunk, so the merged list stays small
    std::vector<std::pair<int, int>> pairs;
    std::vector<int> poses;
  };
  return internal::RunOrderedChunkPipeline<Output>(
      *context.chunks, context.max_in_flight,
      [&](const ChunkOf<Space>& chunk, Output* out) {
        out->pairs.clear();
        out->seen.Clear();
        for (int64_t k = 0; k < chunk.num_features(); ++k) {
          const int32_t g = chunk.features[k];
          if (Excluded(context, g)) continue;
          ObservingPoses<Space>(chunk, k, *context.layout, &out->poses);
          if (context.layout->IsKept(g)) {
            // Kept features couple only with their observing poses.
            const int fu = context.layout->feature_unknown_index[g];
            out->pairs.emplace_back(fu, fu);
            for (int u : out->poses) out->pairs.emplace_back(u, fu);
            continue;
          }
          InsertAllPairs(out->poses, &out->seen, &out->pairs);
        }
        return Status::Ok();
      },
      [&](const ChunkOf<Space>& chunk, Output& out) {
        pairs->insert(pairs->end(), out.pairs.begin(), out.pairs.end());
        Report(context, "pattern", chunk.index + 1);
      });
}

template <class Space>
Status ReducePass(const BasicPassContext<Space>& context,
                  const std::vector<typename Space::Pose>& poses,
                  const std::vector<typename Space::Point>& features, double lambda,
                  ReducedSystem* system) {
  internal::FeatureLookup<typename Space::Point> lookup;
  lookup.by_feature = &features;
  const std::vector<typename Space::PoseFrame> frames = PoseFrames<Space>(poses);
  return internal::RunOrderedChunkPipeline<internal::ReduceOutput<Space>>(
      *context.chunks, context.max_in_flight,
      [&](const ChunkOf<Space>& chunk, internal::ReduceOutput<Space>* out) {
        return internal::ReduceChunk<Space>(context, chunk, poses, frames.data(), lookup, lambda,
                                            out);
      },
      [&](const ChunkOf<Space>& chunk, internal::ReduceOutput<Space>& out) {
        internal::MergeReduced<Space>(out, system);
        Report(context, "reduce", chunk.index + 1);
      });
}

namespace {

// The sink of the one-slot-per-feature overloads.
template <class Space>
CandidateSink<Space> ScatterInto(const BasicPassContext<Space>& context,
                                 std::vector<typename Space::Point>* candidate_features) {
  return [&context, candidate_features](const ChunkOf<Space>& chunk,
                                        const std::vector<typename Space::Point>& candidates) {
    for (int64_t k = 0; k < chunk.num_features(); ++k) {
      const int32_t g = chunk.features[k];
      if (!Excluded(context, g)) (*candidate_features)[g] = candidates[static_cast<size_t>(k)];
    }
    return Status::Ok();
  };
}

}  // namespace

template <class Space>
Status RecoverPass(const BasicPassContext<Space>& context, const BasicRecoveryInput<Space>& input,
                   const CandidateSink<Space>& sink, RecoveryResult* result) {
  *result = RecoveryResult();
  Status sink_status;
  const std::vector<typename Space::PoseFrame> frames = PoseFrames<Space>(input.poses);
  Status status = internal::RunOrderedChunkPipeline<internal::RecoverOutput<Space>>(
      *context.chunks, context.max_in_flight,
      [&](const ChunkOf<Space>& chunk, internal::RecoverOutput<Space>* out) {
        internal::RecoverChunk<Space>(context, chunk, input, frames.data(), out);
        return Status::Ok();
      },
      [&](const ChunkOf<Space>& chunk, internal::RecoverOutput<Space>& out) {
        internal::MergeRecovered(out.sums, result);
        if (sink_status.ok()) sink_status = sink(chunk, out.candidates);
        Report(context, "recover", chunk.index + 1);
      });
  GS_RETURN_IF_ERROR(status);
  return sink_status;
}

template <class Space>
Status RecoverPass(const BasicPassContext<Space>& context, const BasicRecoveryInput<Space>& input,
                   std::vector<typename Space::Point>* candidate_features,
                   RecoveryResult* result) {
  candidate_features->resize(input.features.size());
  return RecoverPass<Space>(context, input, ScatterInto(context, candidate_features), result);
}

template <class Space>
Status RecoverAndReducePass(const BasicPassContext<Space>& context,
                            const BasicRecoveryInput<Space>& input,
                            const CandidateSink<Space>& sink, RecoveryResult* result,
                            const NextReduction& next) {
  Status* const next_status = next.status;
  struct Output {
    internal::RecoverOutput<Space> recover;
    internal::ReduceOutput<Space> reduce;
    Status reduce_status;
    bool reduced = false;
  };
  *result = RecoveryResult();
  *next_status = Status::Ok();
  Status sink_status;
  // Once a chunk's speculative elimination failed, the next system is lost:
  // later chunks skip that half of the work (the recovery goes on).
  std::atomic<bool> next_failed{false};
  const std::vector<typename Space::PoseFrame> frames = PoseFrames<Space>(input.poses);
  const std::vector<typename Space::PoseFrame> candidate_frames =
      PoseFrames<Space>(input.candidate_poses);
  Status status = internal::RunOrderedChunkPipeline<Output>(
      *context.chunks, context.max_in_flight,
      [&](const ChunkOf<Space>& chunk, Output* out) {
        // Recovery first: it gives the candidates of this chunk's features,
        // which are exactly the features the reduce half reads. The reduce
        // at the candidate sums the candidate's chi2 as the recovery would
        // (chunk_pass_kernels.h): the recovery leaves it to the reduce.
        internal::RecoverChunk<Space>(context, chunk, input, frames.data(), &out->recover,
                                      /*with_candidate_chi2=*/false);
        out->reduce_status = Status::Ok();
        out->reduced = !next_failed.load();
        if (out->reduced) {
          internal::FeatureLookup<typename Space::Point> candidates;
          candidates.by_slot = out->recover.candidates.data();
          out->reduce_status = internal::ReduceChunk<Space>(context, chunk, input.candidate_poses,
                                                            candidate_frames.data(), candidates,
                                                            next.lambda, &out->reduce);
          if (!out->reduce_status.ok()) next_failed = true;
        }
        out->recover.sums.candidate_chi2 =
            out->reduced && out->reduce_status.ok()
                ? out->reduce.chi2
                : internal::CandidateChi2<Space>(context, chunk, input.candidate_poses,
                                                 out->recover.candidates);
        return Status::Ok();
      },
      [&](const ChunkOf<Space>& chunk, Output& out) {
        internal::MergeRecovered(out.recover.sums, result);
        if (sink_status.ok()) sink_status = sink(chunk, out.recover.candidates);
        if (next_status->ok()) {
          if (!out.reduce_status.ok()) {
            *next_status = out.reduce_status;
          } else if (!out.reduced) {
            // Skipped after a later chunk failed first (in time).
            *next_status = Status::Numerical("chunk " + std::to_string(chunk.index) +
                                             ": speculative reduce abandoned after a failure");
          } else {
            internal::MergeReduced<Space>(out.reduce, next.system);
          }
        }
        Report(context, "recover+reduce", chunk.index + 1);
      });
  GS_RETURN_IF_ERROR(status);
  return sink_status;
}

template <class Space>
Status RecoverAndReducePass(const BasicPassContext<Space>& context,
                            const BasicRecoveryInput<Space>& input,
                            std::vector<typename Space::Point>* candidate_features,
                            RecoveryResult* result, const NextReduction& next) {
  candidate_features->resize(input.features.size());
  return RecoverAndReducePass<Space>(context, input, ScatterInto(context, candidate_features),
                                     result, next);
}

template <class Space>
Status ObservationsChi2(const BasicPassContext<Space>& context,
                        const std::vector<typename Space::Pose>& poses,
                        const std::vector<typename Space::Point>& features, double* chi2) {
  struct Output {
    double chi2 = 0.0;
  };
  *chi2 = 0.0;
  return internal::RunOrderedChunkPipeline<Output>(
      *context.chunks, context.max_in_flight,
      [&](const ChunkOf<Space>& chunk, Output* out) -> Status {
        out->chi2 = 0.0;
        for (int64_t k = 0; k < chunk.num_features(); ++k) {
          if (Excluded(context, chunk.features[k])) continue;
          out->chi2 += FeatureChi2<Space>(chunk, k, poses, features[chunk.features[k]],
                                          context.kernel);
        }
        return Status::Ok();
      },
      [&](const ChunkOf<Space>&, Output& out) { *chi2 += out.chi2; });
}

// The two problem spaces (core/problem_space.h).
#define GS_INSTANTIATE_CHUNK_PASSES(Space)                                                        \
  template Status ScreenFeatures<Space>(const BasicPassContext<Space>&,                           \
                                        const std::vector<Space::Pose>&,                          \
                                        const std::vector<Space::Point>&, int64_t,                \
                                        ScreeningResult*, ScreenedPattern*);                      \
  template Status CollectReducedPattern<Space>(const BasicPassContext<Space>&,                    \
                                               std::vector<std::pair<int, int>>*);                \
  template Status ReducePass<Space>(const BasicPassContext<Space>&,                               \
                                    const std::vector<Space::Pose>&,                              \
                                    const std::vector<Space::Point>&, double, ReducedSystem*);    \
  template Status RecoverPass<Space>(const BasicPassContext<Space>&,                              \
                                     const BasicRecoveryInput<Space>&,                            \
                                     std::vector<Space::Point>*, RecoveryResult*);                \
  template Status RecoverPass<Space>(const BasicPassContext<Space>&,                              \
                                     const BasicRecoveryInput<Space>&,                            \
                                     const CandidateSink<Space>&, RecoveryResult*);               \
  template Status RecoverAndReducePass<Space>(                                                    \
      const BasicPassContext<Space>&, const BasicRecoveryInput<Space>&,                           \
      std::vector<Space::Point>*, RecoveryResult*, const NextReduction&);                         \
  template Status RecoverAndReducePass<Space>(                                                    \
      const BasicPassContext<Space>&, const BasicRecoveryInput<Space>&,                           \
      const CandidateSink<Space>&, RecoveryResult*, const NextReduction&);                        \
  template Status ObservationsChi2<Space>(const BasicPassContext<Space>&,                         \
                                          const std::vector<Space::Pose>&,                        \
                                          const std::vector<Space::Point>&, double*);

GS_INSTANTIATE_CHUNK_PASSES(Space2d)
GS_INSTANTIATE_CHUNK_PASSES(Space3d)
#undef GS_INSTANTIATE_CHUNK_PASSES

}  // namespace graphslam::core

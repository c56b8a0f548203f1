#include "partition/initialization/pose_graph_initialization.h"

#include <atomic>
#include <string>
#include <vector>

#include "core/internal/ordered_chunk_pipeline.h"
#include "core/point_observation_model.h"
#include "core/range_bearing_model.h"

namespace graphslam::partition {
namespace {

class EmptyChunkSource : public core::ChunkSource {
 public:
  int64_t NumChunks() const override { return 0; }
  Status Load(int64_t index, core::ObservationChunk*) const override {
    return Status::InvalidArgument("the empty chunk source has no chunk " + std::to_string(index));
  }
};

}  // namespace

Status PlaceFeaturesFromFirstSight(int max_chunks_in_flight, const core::ChunkSource& chunks,
                                   core::Problem2d* problem, int64_t* placed_features) {
  GS_CHECK(problem != nullptr && placed_features != nullptr);
  *placed_features = 0;
  // Features from first sight with the current poses. Chunks are
  // feature-complete (docs/formats/observation_chunk.md), so chunks write
  // disjoint features and run in parallel (loading -- read, CRC, zstd,
  // decode -- is most of this pass), as many in flight as the solve allows; a
  // feature met in two chunks is a corrupt store, reported (the first in chunk
  // order), never a race on its slot.
  std::vector<std::atomic<uint8_t>> placed(problem->features.size());
  const auto place = [&](const core::ObservationChunk& chunk, int64_t* placed_here) -> Status {
    *placed_here = 0;
    for (size_t slot = 0; slot < chunk.features.size(); ++slot) {
      const int32_t feature = chunk.features[slot];
      const int64_t first = chunk.feature_begin[slot];
      if (first == chunk.feature_begin[slot + 1]) continue;
      if (placed[feature].exchange(1) != 0)
        return Status::Corruption("chunk " + std::to_string(chunk.index) + ": feature " +
                                  std::to_string(feature) +
                                  " is also in another chunk (chunks must be feature-complete)");
      const core::Observation& o = chunk.observations[static_cast<size_t>(first)];
      const core::Pose2& pose = problem->poses[static_cast<size_t>(o.pose)];
      problem->features[feature] = core::InvertObservation(o.kind, pose, o.z);
      ++*placed_here;
    }
    return Status::Ok();
  };
  GS_RETURN_IF_ERROR(core::internal::RunOrderedChunkPipeline<int64_t>(
      chunks, max_chunks_in_flight, place,
      [&](const core::ObservationChunk&, int64_t placed_here) {
        *placed_features += placed_here;
      }));
  return Status::Ok();
}

Status InitializeFromPoseGraph(const core::SolverOptions& solver, int max_iterations,
                               const core::ChunkSource& chunks, core::Problem2d* problem,
                               PoseGraphInitializationSummary* summary) {
  GS_CHECK(problem != nullptr && summary != nullptr);
  *summary = PoseGraphInitializationSummary();
  core::SolverOptions options = solver;
  options.max_iterations = max_iterations;
  options.checkpoint_callback = nullptr;
  options.resume_from = nullptr;
  options.progress = nullptr;
  // Step 1 on the poses; the features are restored (they have no
  // observations here and must not be touched).
  const std::vector<core::Point2> features = problem->features;
  core::SolverSummary pose_summary;
  const Status solved = core::SolveGraphSlam(options, EmptyChunkSource(), problem, &pose_summary);
  problem->features = features;
  // Not converging within the budget is fine for an initial guess.
  if (!solved.ok() && !solved.IsNumerical()) return solved;
  summary->iterations = pose_summary.iterations;
  summary->initial_chi2 = pose_summary.initial_chi2;
  summary->final_chi2 = pose_summary.final_chi2;

  return PlaceFeaturesFromFirstSight(solver.max_chunks_in_flight, chunks, problem,
                                      &summary->placed_features);
}

}  // namespace graphslam::partition

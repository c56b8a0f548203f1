#include "partition/pose_graph_initialization.h"

#include <vector>

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

  // Step 2: features from first sight with the new poses.
  std::vector<uint8_t> placed(problem->features.size(), 0);
  core::ObservationChunk chunk;
  for (int64_t k = 0; k < chunks.NumChunks(); ++k) {
    GS_RETURN_IF_ERROR(chunks.Load(k, &chunk));
    for (size_t slot = 0; slot < chunk.features.size(); ++slot) {
      const int32_t feature = chunk.features[slot];
      const int64_t first = chunk.feature_begin[slot];
      if (first == chunk.feature_begin[slot + 1] || placed[feature]) continue;
      const core::Observation& o = chunk.observations[static_cast<size_t>(first)];
      const core::Pose2& pose = problem->poses[static_cast<size_t>(o.pose)];
      problem->features[feature] = o.kind == core::ObservationKind::kRangeBearing
                                       ? core::InvertRangeBearing(pose, o.z)
                                       : core::InvertPointObservation(pose, o.z);
      placed[feature] = 1;
      ++summary->placed_features;
    }
  }
  return Status::Ok();
}

}  // namespace graphslam::partition
